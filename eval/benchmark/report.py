"""Benchmark outputs: the ranking table of several trackers (paper Tables 6 and 7: per-object
ADD-PRJ-AUC, the mean over objects, ADD and PRJ AUC with their ranks) as Markdown, LaTeX and CSV;
accuracy curves (paper Fig. 4) as PNG; ``scores.json``; per-frame errors CSV per tracker."""
from __future__ import annotations

import csv
import io
import math
import re
from pathlib import Path

import numpy as np

from ...io.atomic import write_json_atomic, write_text_atomic
from ...viz import pyplot
from ..curves import save_png, style_accuracy_axes
from ..scores import ADD_BOUND_MM, PRJ_BOUND_PX, accuracy_curve
from .score import ERROR_FIELDS, GtIndex, TrackerScores


def _ranks(vals: list[float]) -> list[int]:
    """Rank 1 = highest; ties share the better rank; NaN last."""
    v = [(-x if x == x else math.inf) for x in vals]
    return [1 + sum(1 for w in v if w < x) for x in v]


def _short(name: str, n: int = 12) -> str:
    s = re.sub(r"^\d{3}_", "", str(name))
    return s if len(s) <= n else s[:n - 1] + "."


def ranking_rows(scores: list[TrackerScores]) -> tuple[list[int], list[dict]]:
    """(obj_ids, rows sorted by ADD-PRJ-AUC ascending as in the paper); each row has ``name``,
    ``per_object`` {obj: add_prj_auc}, ``avg``, ``add``, ``prj``, ``add_rank``, ``prj_rank``,
    ``rank`` (by avg), ``sr``."""
    obj_ids = sorted({o for s in scores for o in s.per_object})
    rows = [{"name": s.name, "per_object": {o: s.per_object[o]["add_prj_auc"] for o in s.per_object},
             "avg": s.overall["add_prj_auc"], "add": s.overall["add_auc"], "prj": s.overall["prj_auc"],
             "sr": s.overall["sr_5cm5deg"]} for s in scores]
    for key, rk in (("add", "add_rank"), ("prj", "prj_rank"), ("avg", "rank")):
        for r, k in zip(rows, _ranks([r[key] for r in rows])):
            r[rk] = k
    rows.sort(key=lambda r: (-math.inf if r["avg"] != r["avg"] else r["avg"]))
    return obj_ids, rows


def _f(v, d: int = 1) -> str:
    return "-" if v is None or v != v else f"{v:.{d}f}"


def _object_cells(r: dict, obj_ids: list, best: dict, n_rows: int, bold) -> list[str]:
    """The per-object ADD-PRJ-AUC cells of one ranking row; the best of each column (when there
    are several rows) passed through ``bold``."""
    cells = []
    for o in obj_ids:
        v = r["per_object"].get(o)
        c = _f(v)
        cells.append(bold(c) if v is not None and n_rows > 1 and v == best[o] else c)
    return cells


def ranking_markdown(scores: list[TrackerScores], names: dict) -> str:
    obj_ids, rows = ranking_rows(scores)
    best = {o: max((r["per_object"].get(o, -1) for r in rows), default=None) for o in obj_ids}
    head = ["method"] + [_short(names.get(o, o)) for o in obj_ids] + ["Avg.", "ADD", "PRJ", "SR 5cm5°"]
    lines = ["| " + " | ".join(head) + " |", "|:---|" + "---:|" * (len(head) - 1)]
    for r in rows:
        cells = _object_cells(r, obj_ids, best, len(rows), lambda c: f"**{c}**")
        lines.append("| " + " | ".join([r["name"]] + cells + [_f(r["avg"]), f"{_f(r['add'])} [{r['add_rank']}]",
                                                            f"{_f(r['prj'])} [{r['prj_rank']}]", _f(r["sr"])]) + " |")
    lens = sorted({L for s in scores for L in s.per_length})
    by_name = {s.name: s for s in scores}
    lines += ["", "ADD-PRJ-AUC by subsequence length (short: precision, long: robustness):", "",
              "| method | " + " | ".join(f"L={L}" for L in lens) + " | ms/frame |",
              "|:---|" + "---:|" * (len(lens) + 1)]
    for r in rows:
        s = by_name[r["name"]]
        ms = s.counts.get("mean_time_s")
        lines.append("| " + " | ".join([r["name"]] + [_f(s.per_length.get(L, {}).get("add_prj_auc")) for L in lens]
                                        + ["-" if ms is None or ms != ms else f"{1e3 * ms:.0f}"]) + " |")
    return ("ADD-PRJ-AUC per object (ADD-S for the symmetric set), the mean over objects (Avg.), "
            "ADD(-S)-AUC and PRJ-AUC with ranks in brackets, SR at 5 cm / 5 deg for reference.\n\n"
            + "\n".join(lines) + "\n")


def _tex(s: str) -> str:
    for a, b in (("\\", r"\textbackslash{}"), ("_", r"\_"), ("%", r"\%"), ("&", r"\&"), ("#", r"\#")):
        s = s.replace(a, b)
    return s


def ranking_latex(scores: list[TrackerScores], names: dict, caption: str = "") -> str:
    obj_ids, rows = ranking_rows(scores)
    best = {o: max((r["per_object"].get(o, -1) for r in rows), default=None) for o in obj_ids}
    cols = len(obj_ids) + 4
    out = [r"\begin{table*}", r"\centering", r"\scriptsize", r"\setlength\tabcolsep{2.5pt}",
           r"\begin{tabular}{l" + "c" * cols + "}", r"\toprule",
           " & ".join(["Method"] + [rf"\rotatebox{{60}}{{{_tex(_short(names.get(o, o)))}}}" for o in obj_ids]
                      + [r"Avg.$^\uparrow$", "ADD", "PRJ", r"SR"]) + r" \\", r"\midrule"]
    for r in rows:
        cells = _object_cells(r, obj_ids, best, len(rows), lambda c: rf"\textbf{{{c}}}")
        out.append(" & ".join([_tex(r["name"])] + cells + [_f(r["avg"]), f"{_f(r['add'])}$^{{[{r['add_rank']}]}}$",
                                                           f"{_f(r['prj'])}$^{{[{r['prj_rank']}]}}$", _f(r["sr"])])
                   + r" \\")
    out += [r"\bottomrule", r"\end{tabular}"]
    if caption:
        out.append(r"\caption{" + _tex(caption) + "}")
    out.append(r"\end{table*}")
    return "\n".join(out) + "\n"


def ranking_csv(scores: list[TrackerScores], names: dict) -> str:
    obj_ids, rows = ranking_rows(scores)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["method"] + [f"{names.get(o, o)}" for o in obj_ids]
               + ["add_prj_auc", "rank", "add_auc", "add_rank", "prj_auc", "prj_rank", "sr_5cm5deg"])
    for r in rows:
        w.writerow([r["name"]] + [f"{r['per_object'][o]:.4f}" if o in r["per_object"] else "" for o in obj_ids]
                   + [f"{r['avg']:.4f}", r["rank"], f"{r['add']:.4f}", r["add_rank"], f"{r['prj']:.4f}",
                      r["prj_rank"], f"{r['sr']:.4f}"])
    return buf.getvalue()


def plot_tracker_curves(scores: list[TrackerScores], gti: GtIndex, out_png: str | Path,
                        n_thresholds: int = 201, title: str = "") -> Path:
    """Accuracy vs threshold, ADD(-S) on 0..100 mm and PRJ on 0..10 px, one curve per tracker (the
    mean over objects of the per-object curves: its normalised area is the tracker's AUC)."""
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4), constrained_layout=True)
    obj_ids = sorted(set(gti.obj_id.tolist()))
    cmap = plt.get_cmap("tab10")
    for ax, key, bound, xl in ((axes[0], "add_s_mm", ADD_BOUND_MM, "ADD(-S) threshold (mm)"),
                               (axes[1], "prj_px", PRJ_BOUND_PX, "PRJ threshold (px)")):
        thr = np.linspace(0, bound, n_thresholds)
        for i, s in enumerate(sorted(scores, key=lambda s: -s.overall["add_prj_auc"])):
            curves = [accuracy_curve(s.errors[key][gti.obj_id == o], thr) for o in obj_ids]
            mean = np.mean(curves, axis=0)
            a = s.overall["add_auc" if key == "add_s_mm" else "prj_auc"]
            ax.plot(thr, mean, lw=2, color=cmap(i % 10), label=f"{s.name} ({a:.1f})")
        style_accuracy_axes(ax, bound, xl)
        ax.legend(fontsize=8, loc="lower right")
    return save_png(fig, out_png, 110, title)


def errors_csv(s: TrackerScores, gti: GtIndex) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["sub_id", "scene_id", "im_id", "obj_id", "length"] + list(ERROR_FIELDS))
    cols = [s.errors[k] for k in ERROR_FIELDS]
    for i in range(len(gti)):
        w.writerow([int(gti.sub_id[i]), int(gti.scene_id[i]), int(gti.im_id[i]), int(gti.obj_id[i]),
                    int(gti.length[i])] + ["" if not np.isfinite(c[i]) else f"{c[i]:.6g}" for c in cols])
    return buf.getvalue()


def _safe(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("_") or "tracker"


def write_report(scores: list[TrackerScores], gti: GtIndex, cfg: dict, out_dir: str | Path, names: dict,
                 options: dict, curves: bool = True, per_frame: bool = True) -> dict[str, Path]:
    """Write ranking.{md,tex,csv}, scores.json, curves.png and errors_<tracker>.csv into ``out_dir``."""
    out = Path(out_dir)
    paths = {}
    cap = (f"Benchmark {cfg['protocol']} ({len(cfg['subsequences'])} subsequences, seed {cfg['seed']}): "
           f"ADD-PRJ-AUC per object; ADD and PRJ AUC with ranks.")
    for ext, text in (("md", ranking_markdown(scores, names)), ("tex", ranking_latex(scores, names, cap)),
                      ("csv", ranking_csv(scores, names))):
        p = out / f"ranking.{ext}"
        write_text_atomic(p, text)
        paths[f"ranking.{ext}"] = p
    js = {"protocol": cfg["protocol"], "seed": cfg["seed"], "n_subsequences": len(cfg["subsequences"]),
          "options": options, "trackers": {}}
    for s in scores:
        js["trackers"][s.name] = {**s.overall, "counts": s.counts,
                                  "per_length": {str(k): v for k, v in s.per_length.items()},
                                  "per_object": {str(o): {"name": names.get(o, str(o)), **v}
                                                 for o, v in s.per_object.items()}}
    write_json_atomic(out / "scores.json", js)
    paths["scores.json"] = out / "scores.json"
    if curves:
        paths["curves.png"] = plot_tracker_curves(scores, gti, out / "curves.png")
    if per_frame:
        for s in scores:
            p = out / f"errors_{_safe(s.name)}.csv"
            write_text_atomic(p, errors_csv(s, gti))
            paths[p.name] = p
    return paths
