"""Pose-error metrics (tx/ty/tz/R/PRJ/ADD/ADD-S), AUC scores, tables and curves."""
