"""Pose-error metrics (tx/ty/tz/R/PRJ/ADD/ADD-S), AUC/SR scores, matching, tables and curves.

Main entry points::

    from ycbvss.eval import evaluate, EvalOptions, write_outputs
    result = evaluate(dataset, estimates, EvalOptions(symmetric_obj_ids=(13,)))
    write_outputs(result, "out/")
"""
from .evaluate import EstArrays, EvalOptions, EvalResult, GtArrays, evaluate, evaluate_arrays
from .metrics import add_adds_mm, add_mm, adds_mm, pose_errors, prj_px, re_deg, te_axes_mm, te_mm
from .model_points import ModelPoints
from .outputs import result_error_table, result_score_table, summary_text, write_outputs
from .scores import accuracy_curve, auc, object_scores, overall_scores, success_rate
from .tables import Row, Table, ablation_table, error_table, score_table, to_csv, to_latex, to_markdown, write_table

__all__ = [
    "EstArrays", "EvalOptions", "EvalResult", "GtArrays", "evaluate", "evaluate_arrays",
    "add_adds_mm", "add_mm", "adds_mm", "pose_errors", "prj_px", "re_deg", "te_axes_mm", "te_mm",
    "ModelPoints", "result_error_table", "result_score_table", "summary_text", "write_outputs",
    "accuracy_curve", "auc", "object_scores", "overall_scores", "success_rate",
    "Row", "Table", "ablation_table", "error_table", "score_table", "to_csv", "to_latex", "to_markdown",
    "write_table",
]
