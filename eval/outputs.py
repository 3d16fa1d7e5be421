"""Write an :class:`~ycbvss.eval.evaluate.EvalResult` to a folder (all files atomic).

``errors.csv`` (one row per GT instance, empty fields = no estimate), ``summary.json``,
``table.{md,csv,tex}`` (paper Table 4 layout: mean tx ty tz R PRJ per object + "all"),
``scores.{md,csv,tex}`` (AUC / SR per object + mean over objects), ``curves.png``.
"""
from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from ..io.atomic import write_json_atomic, write_text_atomic
from .curves import plot_curves
from .evaluate import ERROR_COLUMNS, EvalResult
from .symmetric_sets import PRESETS, header_label, parse_symmetric
from .tables import Table, error_table, score_table, to_markdown, write_table

_INT_COLS = {"scene_id", "im_id", "obj_id", "gt_id", "symmetric"}


def errors_csv_text(errors: dict) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    cols = [c for c in ERROR_COLUMNS if c in errors]
    w.writerow(cols)
    arrays = [np.asarray(errors[c]) for c in cols]
    n = len(arrays[0]) if arrays else 0
    fmt = ["{:d}" if c in _INT_COLS else "{:.6f}" for c in cols]
    for i in range(n):
        row = []
        for c, a, f in zip(cols, arrays, fmt):
            v = a[i]
            if c in _INT_COLS:
                row.append(str(int(v)))
            else:
                v = float(v)
                row.append("" if not math.isfinite(v) else f.format(v))
        w.writerow(row)
    return buf.getvalue()


def _json_safe(o):
    if isinstance(o, dict):
        return {str(k): _json_safe(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_json_safe(v) for v in o]
    if isinstance(o, (float, np.floating)):
        return None if not math.isfinite(float(o)) else float(o)
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, np.bool_):
        return bool(o)
    return o


def result_error_table(result: EvalResult, all_from: str = "instances", extra_rows=None,
                       caption: str = "") -> Table:
    """Table 4 layout of a result. ``all_from``: "instances" (mean over all GT instances with an
    estimate, default) or "objects" (mean of the per-object means)."""
    if all_from == "objects":
        keys = ("mean_tx_mm", "mean_ty_mm", "mean_tz_mm", "mean_r_deg", "mean_prj_px")
        all_row = {k: float(np.nanmean([v.get(k, np.nan) for v in result.per_object.values()]))
                   for k in keys}
    else:
        all_row = result.summary["all_instances"]
    return error_table(result.per_object, result.names, result.textureless, all_row, extra_rows,
                       caption=caption or _sym_caption(result))


def _sym_label(result: EvalResult) -> str:
    """The ADD-S set's name; derived from the ids actually used when they are not the named preset's."""
    o = result.summary.get("options", {})
    label, ids = o.get("symmetric_set", "paper"), tuple(sorted(o.get("symmetric_obj_ids", ())))
    return label if PRESETS.get(label) == ids else parse_symmetric([str(i) for i in ids])[1]


def _sym_caption(result: EvalResult) -> str:
    return header_label(_sym_label(result), result.summary.get("options", {}).get("symmetric_obj_ids", ()))


def result_score_table(result: EvalResult, caption: str = "") -> Table:
    t = score_table(result.per_object, result.summary, result.names, result.textureless,
                    caption=caption or _sym_caption(result))
    t.columns[0] = f"ADD(-S) AUC [{_sym_label(result)}]"
    return t


def write_outputs(result: EvalResult, out_dir: str | Path, curves: bool = True) -> dict[str, Path]:
    """Write all outputs into ``out_dir``; returns name -> path."""
    out_dir = Path(out_dir)
    paths = {}
    paths["errors.csv"] = out_dir / "errors.csv"
    write_text_atomic(paths["errors.csv"], errors_csv_text(result.errors))
    paths["summary.json"] = out_dir / "summary.json"
    write_json_atomic(paths["summary.json"], _json_safe(result.summary))
    for p in write_table(result_error_table(result), out_dir, "table"):
        paths[p.name] = p
    for p in write_table(result_score_table(result), out_dir, "scores"):
        paths[p.name] = p
    if curves:
        e = result.errors
        objs = sorted(result.per_object)
        add = {o: e["add_s_mm"][e["obj_id"] == o] for o in objs}
        prj = {o: e["prj_px"][e["obj_id"] == o] for o in objs}
        paths["curves.png"] = plot_curves(add, prj, out_dir / "curves.png", result.names,
                                          result.summary["options"]["add_bound_mm"],
                                          result.summary["options"]["prj_bound_px"])
    return paths


def summary_text(result: EvalResult) -> str:
    """The two tables as Markdown plus the overall scores (what the CLI prints)."""
    s = result.summary
    lines = [to_markdown(result_error_table(result)), to_markdown(result_score_table(result)),
             f"ADD(-S)-AUC {s['add_auc']:.2f}  PRJ-AUC {s['prj_auc']:.2f}  "
             f"ADD-PRJ-AUC {s['add_prj_auc']:.2f}  SR(5cm,5deg) {s['sr_5cm5deg']:.2f}  "
             f"({s['counts']['n_matched']}/{s['counts']['n_gt']} GT instances with an estimate)"]
    return "\n".join(lines)
