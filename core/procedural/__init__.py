"""Procedural multi-object scenes built in code (the demo default that needs no download)."""
