"""Outputs of `ycbvss validate` / `ycbvss demo`: tables (Markdown/CSV/LaTeX via ycbvss.eval.tables),
pose files (BOP19 CSV), per-pose errors, overlays, curves, ``summary.json`` and one self-contained
HTML report (PNGs inlined as base64; links only to files that exist)."""
from __future__ import annotations

import base64
import datetime as _dt
import html
import json
import math
from pathlib import Path

import numpy as np

from ..eval.curves import plot_curves
from ..eval.tables import Row, Table, _fmt, ablation_table, error_table, to_markdown, write_table
from ..io.atomic import write_json_atomic, write_text_atomic
from ..io.images import read_rgb
from ..io.results import Estimate, write_bop19_csv
from ..refine.confidence import STATUSES
from ..refine.options import options_to_json
from ..progress import progress
from ..render import Renderer
from .figures import error_curves_png, overlay_figure, render_instances, write_overlay
from .pose_sets import ERR5, PAPER_REFERENCE_ROWS, PAPER_TABLE5, means, object_means


# ----------------------------------------------------------------------------- tables
def _vals(row) -> dict:
    return {k: v for k, v in zip(ERR5, row)}


def table4(errs_refined: dict, errs_initial: dict | None, models: dict, caption: str,
           reference: bool = True, extra_label: str = "initial"):
    """Paper Table 4 layout (ycbvss.eval.tables.error_table) + "initial" + the paper's reference rows."""
    names = {o: models[o].label.rstrip("*") for o in errs_refined}
    tl = {o: bool(models[o].textureless) for o in errs_refined}
    extra = [(extra_label, means(errs_initial))] if errs_initial is not None else []
    t = error_table(object_means(errs_refined), names, tl, all_row=means(errs_refined), extra_rows=extra,
                    caption=caption)
    if reference:
        for i, (label, vals) in enumerate(PAPER_REFERENCE_ROWS):
            t.rows.append(Row(label, list(vals), rule_before=(i == 0)))
    return t


def table5(errs: dict, caption: str):
    order = [v for v in ("w/o f_edge", "w/o f_point", "w/o f_t", "using all") if v in errs]
    t = ablation_table([(v, means(errs[v])) for v in order], caption=caption)
    for i, (label, vals) in enumerate(PAPER_TABLE5):
        t.rows.append(Row("paper: " + label, list(vals), rule_before=(i == 0)))
    return t


def summary_table(errs: dict, pr):
    """Mean / median ADD(-S) and PRJ per pose set (initial, refined variants)."""
    t = Table(["mean ADD (mm)", "median ADD (mm)", "mean PRJ (px)", "median PRJ (px)"],
              label_header="pose set", digits=2,
              caption=f"Initial poses: GT + calibrated random deviation (targets: ADD {pr.target_add_mm:g} mm, "
                      f"PRJ {pr.target_prj_px:g} px). ADD-S for symmetric objects.")
    for name, e in errs.items():
        a = np.concatenate([v["add_mm"] for v in e.values()])
        p = np.concatenate([v["prj_px"] for v in e.values()])
        t.rows.append(Row(f"{name} ({int(np.isfinite(a).sum())} pairs)",
                          [_nanstat(np.nanmean, a), _nanstat(np.nanmedian, a), _nanstat(np.nanmean, p),
                           _nanstat(np.nanmedian, p)]))
    return t


def _nanstat(fn, x):
    x = np.asarray(x, np.float64)
    return float(fn(x)) if np.isfinite(x).any() else None


def timings_table(stages):
    t = Table(["time (s)"], label_header="stage", digits=1)
    for k, v in stages.times.items():
        t.rows.append(Row(k, [v]))
    t.rows.append(Row("total", [stages.total_s], rule_before=True))
    return t


def table_html(t, title: str = "") -> str:
    h = ['<table class="res">']
    if title:
        h.append(f"<caption>{html.escape(title)}</caption>")
    h.append("<thead><tr><th>" + html.escape(t.label_header) + "</th>" +
             "".join(f"<th>{html.escape(c)}</th>" for c in t.columns) + "</tr></thead><tbody>")
    for r in t.rows:
        cls = ' class="rule"' if r.rule_before else ""
        cells = []
        for c, v in enumerate(r.values):
            s = html.escape(_fmt(v, t.digits))
            cells.append(f"<td><b>{s}</b></td>" if (r.bold and r.bold[c] and s != "-") else f"<td>{s}</td>")
        lab = html.escape(r.label) + ("*" if r.mark else "")
        h.append(f"<tr{cls}><td class=\"lab\">{lab}</td>{''.join(cells)}</tr>")
    h.append("</tbody></table>")
    if t.caption:
        h.append(f'<p class="cap">{html.escape(t.caption)}</p>')
    return "".join(h)


def write_tables(t, out_dir: Path, stem: str) -> list[Path]:
    return write_table(t, out_dir, stem)


def table_text(t) -> str:
    """Markdown without the caption (for the terminal)."""
    cap, t.caption = t.caption, ""
    try:
        return to_markdown(t)
    finally:
        t.caption = cap


# ----------------------------------------------------------------------------- pose files
def write_poses_csv(path: Path, poses: dict, marks: dict | None = None) -> Path:
    """``poses`` {(scene, im, obj): 4x4} as a BOP19 CSV. ``marks`` {(scene, im, obj): (status, confidence,
    reason)} (:func:`ycbvss.pipeline.validate.refine_all`): each row's score is the refiner's confidence
    (a failed pose scores <= 0.1), as ``ycbvss refine`` writes it; without marks (poses the refiner did
    not make, e.g. the perturbed initial ones) the score is 1."""
    def score(k) -> float:
        return float(marks[k][1]) if marks is not None and k in marks else 1.0
    ests = [Estimate(int(k[0]), int(k[1]), int(k[2]), score(k), np.asarray(T)) for k, T in sorted(poses.items())]
    write_bop19_csv(path, ests)
    return path


def status_counts(marks: dict) -> dict:
    """{status: number of poses} over ``marks`` (every status of
    :data:`ycbvss.refine.confidence.STATUSES`, zeros included)."""
    out = {s: 0 for s in STATUSES}
    for st, _, _ in marks.values():
        out[st] = out.get(st, 0) + 1
    return out


def status_table(marks: dict, models: dict, errs: dict | None = None, caption: str = "") -> Table:
    """Per object: poses, how many the refiner called ``converged`` / ``uncertain`` / ``failed``, their
    mean confidence (the BOP19 score); with ``errs`` (per-object pose-set errors against exact GT, keys
    and ``add_mm``) also the poses with ADD > 10 mm and how many of those were flagged (not
    ``converged``). Last row: all poses."""
    add = {}
    for e in (errs or {}).values():
        for k, a in zip(e["keys"], e["add_mm"]):
            add[tuple(int(x) for x in k)] = float(a)
    cols = ["poses", *STATUSES, "mean confidence"] + (["ADD > 10 mm", "of those flagged"] if errs is not None else [])
    t = Table(cols, label_header="object", digits=3, caption=caption)

    def row(keys) -> list:
        ms = [marks[k] for k in keys]
        v: list = [len(ms)] + [sum(1 for m in ms if m[0] == s) for s in STATUSES]
        v.append(float(np.mean([m[1] for m in ms])) if ms else None)
        if errs is not None:
            far = [k for k in keys if add.get(tuple(int(x) for x in k), 0.0) > 10.0]
            v += [len(far), sum(1 for k in far if marks[k][0] != "converged")]
        return v

    for o in sorted({k[-1] for k in marks}):
        keys = sorted(k for k in marks if k[-1] == o)
        t.rows.append(Row(models[o].label.rstrip("*") if o in models else str(o), row(keys),
                          mark=bool(getattr(models.get(o), "textureless", False))))
    t.rows.append(Row("all", row(sorted(marks)), rule_before=True))
    return t


def write_errors_csv(path: Path, errs: dict) -> Path:
    lines = ["pose_set,scene_id,im_id,obj_id,tx_mm,ty_mm,tz_mm,r_deg,prj_px,add_mm"]
    for name, per_obj in errs.items():
        for oid, e in per_obj.items():
            for i, k in enumerate(e["keys"]):
                vals = ",".join("" if not math.isfinite(float(e[c][i])) else f"{float(e[c][i]):.6g}"
                                for c in (*ERR5, "add_mm"))
                lines.append(f"{name},{k[0]},{k[1]},{k[2]},{vals}")
    write_text_atomic(path, "\n".join(lines) + "\n")
    return path


# ----------------------------------------------------------------------------- figures
def _overlays(out_dir: Path, scenes, models, sets: dict, gt: dict | None, n: int, originals: dict,
              image_label: str, original_label: str = "original") -> list[Path]:
    """Overlay PNGs for ``n`` frames spread over the first scene. ``sets``: name -> pose dict."""
    if n <= 0 or not scenes:
        return []
    sc = scenes[0]
    idx = sorted(set(np.linspace(0, len(sc.frames) - 1, min(n, len(sc.frames))).round().astype(int).tolist()))
    r = Renderer()
    paths = []
    for i in progress(idx, desc="overlays", unit="frame"):
        f = sc.frames[i]
        img = f.load_rgb()
        K, W, H = f.camera.K, f.camera.width, f.camera.height
        oids = [inst.obj_id for inst in f.instances]

        def omap(poses):
            return render_instances(r, models, K, W, H, {o: poses[(sc.scene_id, f.im_id, o)] for o in oids
                                                         if (sc.scene_id, f.im_id, o) in poses})
        gt_map = omap(gt) if gt is not None else None
        maps = {name: omap(P) for name, P in sets.items()}
        orig = None
        op = originals.get((sc.scene_id, f.im_id))
        if op is not None and Path(op).is_file():
            orig = read_rgb(op)
            if orig.shape[:2] != img.shape[:2]:
                orig = None
        fig = overlay_figure(img, gt_map, maps, original_rgb=orig, image_label=image_label,
                             original_label=original_label)
        paths.append(write_overlay(out_dir / f"overlay_s{sc.scene_id:06d}_{f.im_id:06d}.png", fig))
    return paths


def _curves(out_dir: Path, errs: dict, models: dict) -> list[Path]:
    series = {name: {"add_mm": np.concatenate([v["add_mm"] for v in e.values()]),
                     "prj_px": np.concatenate([v["prj_px"] for v in e.values()])} for name, e in errs.items()}
    init_add = np.nanmean(series["initial"]["add_mm"]) if "initial" in series else 30.0
    paths = [error_curves_png(out_dir / "error_curves.png", series, add_max_mm=max(10.0, 2.0 * init_add),
                              prj_max_px=10.0, title="accuracy: fraction of (view, object) pairs below a threshold")]
    ref = errs.get("using all")
    if ref is not None:
        names = {o: models[o].label for o in ref}
        add_max = _nice_max([v["add_mm"] for v in ref.values()])
        prj_max = _nice_max([v["prj_px"] for v in ref.values()])
        paths.append(plot_curves({o: v["add_mm"] for o, v in ref.items()}, {o: v["prj_px"] for o, v in ref.items()},
                                 out_dir / "curves_per_object_refined.png", names=names,
                                 add_bound_mm=add_max, prj_bound_px=prj_max,
                                 title=f"refined poses, per object (ADD(-S) 0-{add_max:g} mm, PRJ 0-{prj_max:g} px: "
                                       "axes scaled to the data)"))
    return paths


def _nice_max(arrays) -> float:
    """Axis end for error curves: 1.25 x the 99th percentile, rounded up to 1, 2 or 5 x 10^k."""
    v = np.concatenate([np.asarray(a, np.float64).ravel() for a in arrays]) if arrays else np.zeros(0)
    v = v[np.isfinite(v)]
    x = 1.25 * float(np.percentile(v, 99)) if v.size else 1.0
    x = max(x, 1e-3)
    k = 10.0 ** np.floor(np.log10(x))
    return float(next(m * k for m in (1, 2, 5, 10) if m * k >= x))


# ----------------------------------------------------------------------------- HTML
CSS = """body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:24px auto;max-width:1200px;
color:#222;line-height:1.4}h1{font-size:1.5em}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ddd}
table.res{border-collapse:collapse;margin:8px 0;font-size:0.92em}table.res td,table.res th{padding:3px 10px;
text-align:right;border-bottom:1px solid #eee}table.res td.lab,table.res th:first-child{text-align:left}
table.res tr.rule td{border-top:2px solid #888}caption{caption-side:top;text-align:left;font-weight:600;
padding:4px 0}p.cap{color:#555;font-size:0.85em;margin-top:2px}img{max-width:100%;border:1px solid #ddd;
margin:6px 0}code{background:#f4f4f4;padding:1px 4px}.kv td{padding:2px 12px 2px 0}.files li{font-family:monospace}"""


def _img_tag(path: Path, alt: str) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


def write_html(path: Path, title: str, info: list[tuple[str, str]], sections: list[tuple[str, str]],
               files: list[Path]) -> Path:
    """One self-contained HTML page: a key/value header, sections of raw HTML, links to ``files``
    (relative to the page, only those that exist)."""
    root = path.parent
    parts = ["<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">",
             f"<title>{html.escape(title)}</title><style>{CSS}</style></head><body>",
             f"<h1>{html.escape(title)}</h1><table class=\"kv\">"]
    parts += [f"<tr><td><b>{html.escape(k)}</b></td><td>{html.escape(v)}</td></tr>" for k, v in info]
    parts.append("</table>")
    for head, body in sections:
        parts.append(f"<h2>{html.escape(head)}</h2>{body}")
    existing = [p for p in files if Path(p).is_file()]
    if existing:
        parts.append("<h2>Files</h2><ul class=\"files\">")
        for p in existing:
            rel = Path(p).resolve().relative_to(root.resolve()).as_posix()
            parts.append(f'<li><a href="{html.escape(rel)}">{html.escape(rel)}</a></li>')
        parts.append("</ul>")
    parts.append(f"<p class=\"cap\">generated by ycbvss on {_dt.datetime.now().isoformat(timespec='seconds')}</p>")
    parts.append("</body></html>")
    write_text_atomic(path, "\n".join(parts) + "\n")
    return path


# ----------------------------------------------------------------------------- writers
def write_validation_outputs(out: Path, opts, scenes, models, gt, Ks, pr, refined, errs, stages, originals,
                             src_layout, errs_kf: dict | None = None) -> dict:
    """Everything `ycbvss validate` writes into ``out``: tables (Table 4/5 layouts, summary), pose and
    error CSVs, curves, overlays, ``summary.json`` and ``report.html``. ``errs``/``errs_kf``: per-variant
    pose-set errors (:func:`ycbvss.pipeline.pose_sets.pose_set_errors`) on all / the keyframe pairs;
    ``pr`` the perturbation result; ``refined`` variant -> poses (+ "_stats"). Returns the summary."""
    n_pairs = len(gt)
    kf_extra = {f"{k} (keyframes)": v for k, v in (errs_kf or {}).items() if k not in ("initial", "using all")}
    (t4, t5, ts), files = _validation_tables(out / "tables", errs, errs_kf, kf_extra, models, pr, n_pairs)
    files += _validation_pose_files(out / "poses", pr, refined, {**errs, **kf_extra})
    marks = refined.get("_marks", {}).get("using all", {})
    t_st = status_table(marks, models, errs["using all"],
                        caption="Status and confidence the refiner gave each pose (all terms); the confidence is the "
                                "score of poses/refined_poses.csv (BOP19). Against the exact GT: poses with ADD > 10 mm "
                                "and how many of them are flagged (uncertain or failed).")
    files += write_tables(t_st, out / "tables", "status")
    curve_paths = _curves(out / "figures", errs, models)
    ov = _overlays(out / "figures", scenes, models, {"initial": pr.poses, "refined": refined["using all"]}, gt,
                   opts.overlays, originals, image_label="YCBV-SS" if not opts.gt_exact else "rendered")
    files += curve_paths + ov
    m_init, m_ref = means(errs["initial"]), means(errs["using all"])
    summary = {
        "mode": "validate", "dataset": str(opts.dataset), "out": str(out), "seed": opts.seed,
        "scenes": [sc.scene_id for sc in scenes], "frames": sum(len(sc.frames) for sc in scenes),
        "pairs": n_pairs, "objects": sorted({k[-1] for k in gt}),
        "initial": {"target_add_mm": pr.target_add_mm, "target_prj_px": pr.target_prj_px,
                    "achieved_add_mm": pr.add_mm, "achieved_prj_px": pr.prj_px, **m_init},
        "refined": m_ref,
        "variants_keyframes": {v: means(e) for v, e in (errs_kf or {}).items()},
        "refine_stats": {v: {str(s): d for s, d in st.items()} for v, st in refined["_stats"].items()},
        "status": status_counts(marks),
        "refine_options": options_to_json(getattr(opts, "refine_options", None)),
        "timings_s": dict(stages.times), **(opts.extra_info or {}),
    }
    info = [("dataset", str(opts.dataset)), ("scenes / frames / pairs",
                                             f"{len(scenes)} / {summary['frames']} / {n_pairs}"),
            ("initial poses", pr.summary()),
            ("refined (all terms)", f"mean ADD {m_ref['add_mm']:.3f} mm, mean PRJ {m_ref['prj_px']:.3f} px")]
    info += [(k, str(v)) for k, v in (opts.extra_info or {}).items()]
    if summary["refine_options"]:
        info.append(("refiner options (--options)", json.dumps(summary["refine_options"], sort_keys=True)))
    sections = _validation_sections(t4, t5, ts, curve_paths, ov, timings_table(stages))
    sections.insert(1, ("Status and confidence of the refined poses", table_html(t_st)))
    summary_path = out / "summary.json"
    write_json_atomic(summary_path, summary)
    files.append(summary_path)
    report = write_html(out / "report.html", opts.title, info, sections, files)
    summary["report"] = str(report)
    summary["table4_md"] = table_text(t4)
    summary["table5_md"] = table_text(t5) if t5 is not None else ""
    summary["status_md"] = table_text(t_st)
    summary["files"] = [str(p) for p in files] + [str(report)]
    return summary


def _validation_tables(tdir: Path, errs: dict, errs_kf: dict | None, kf_extra: dict, models: dict, pr,
                       n_pairs: int) -> tuple[tuple, list[Path]]:
    """((Table 4, Table 5 or None, summary table), files written) of a validation run."""
    files: list[Path] = []
    t4 = table4(errs["using all"], errs["initial"], models,
                caption=f"Bundle pose refinement on {n_pairs} (view, object) pairs with exact GT: mean absolute "
                        "errors. Textureless objects marked *. Below the last rule: the paper's numbers "
                        "(Li et al., YCBV-SS) and BCOT's binocular results, for reference only (other data).")
    files += write_tables(t4, tdir, "table4")
    t5 = None
    if errs_kf:
        n_kf = len({k for e in errs_kf["using all"].values() for k in e["keys"]})
        t5 = table5({k: v for k, v in errs_kf.items() if k != "initial"},
                    caption=f"Ablation on the keyframes ({n_kf} (view, object) pairs): the same initial poses refined "
                            "with one cost term removed (best in bold). Below the rule: the paper's Table 5.")
        files += write_tables(t5, tdir, "table5")
    ts = summary_table({**errs, **kf_extra}, pr)
    files += write_tables(ts, tdir, "summary")
    return (t4, t5, ts), files


def _validation_pose_files(pdir: Path, pr, refined: dict, all_errs: dict) -> list[Path]:
    """Initial and refined poses of every variant as BOP19 CSVs, and the per-pose errors CSV."""
    marks = refined.get("_marks", {})
    files = [write_poses_csv(pdir / "initial_poses.csv", pr.poses),
             write_poses_csv(pdir / "refined_poses.csv", refined["using all"], marks.get("using all"))]
    for v in refined:
        if v not in ("using all", "_stats", "_marks"):
            files.append(write_poses_csv(pdir / f"refined_{v.replace('/', '').replace(' ', '_')}.csv", refined[v],
                                         marks.get(v)))
    files.append(write_errors_csv(pdir / "errors_per_pose.csv", all_errs))
    return files


def _validation_sections(t4, t5, ts, curve_paths: list[Path], ov: list[Path], tt) -> list[tuple[str, str]]:
    """The HTML report's (title, html) sections of a validation run."""
    sections = [("Table 4 layout: per-object errors after refinement", table_html(t4))]
    if t5 is not None:
        sections.append(("Table 5 layout: ablation", table_html(t5)))
    sections.append(("Initial vs refined", table_html(ts)))
    sections.append(("Error curves", "".join(_img_tag(p, p.name) for p in curve_paths)))
    if ov:
        sections.append(("Overlays (white: GT; red: initial; green: refined)",
                         "".join(f"<p>{html.escape(p.name)}</p>{_img_tag(p, p.name)}" for p in ov)))
    sections.append(("Timings", table_html(tt)))
    return sections


def write_real_outputs(out: Path, opts, scenes, models, orig, Ks, refined, diff, stages) -> dict:
    tdir, fdir, pdir = out / "tables", out / "figures", out / "poses"
    files: list[Path] = []
    names = {o: models[o].label for o in diff}
    tl = {o: bool(models[o].textureless) for o in diff}
    t = error_table(object_means(diff), names, tl, all_row=means(diff),
                    caption="Original annotations vs bundle-refined poses: mean absolute difference per object "
                            "(the paper's last row of Table 4). Below the rule: the paper's value on YCB-V.")
    ref = dict(PAPER_REFERENCE_ROWS)["YCBV original (paper)"]
    t.rows.append(Row("paper: YCBV original vs refined", list(ref), rule_before=True))
    files += write_tables(t, tdir, "original_vs_refined")
    files.append(write_poses_csv(pdir / "original_poses.csv", orig))
    marks = refined.get("_marks", {}).get("using all", {})
    files.append(write_poses_csv(pdir / "refined_poses.csv", refined["using all"], marks))
    files.append(write_errors_csv(pdir / "differences_per_pose.csv", {"original_vs_refined": diff}))
    t_st = status_table(marks, models, caption="Status and confidence the refiner gave each refined pose; the "
                                               "confidence is the score of poses/refined_poses.csv (BOP19).")
    files += write_tables(t_st, tdir, "status")
    ov = _overlays(fdir, scenes, models, {"original": orig, "refined": refined["using all"]}, None, opts.overlays,
                   {}, image_label="real frame")
    files += ov
    tt = timings_table(stages)
    m = means(diff)
    summary = {"mode": "real", "dataset": str(opts.dataset), "out": str(out),
               "scenes": [sc.scene_id for sc in scenes], "frames": sum(len(sc.frames) for sc in scenes),
               "pairs": len(orig), "original_vs_refined": m,
               "refine_stats": {v: {str(s): d for s, d in st.items()} for v, st in refined["_stats"].items()},
               "status": status_counts(marks),
               "refine_options": options_to_json(getattr(opts, "refine_options", None)),
               "timings_s": dict(stages.times)}
    write_json_atomic(out / "summary.json", summary)
    files.append(out / "summary.json")
    info = [("dataset", str(opts.dataset)), ("scenes / frames / pairs",
                                             f"{len(scenes)} / {summary['frames']} / {len(orig)}"),
            ("original vs refined", f"mean |dt| = ({m['tx_mm']:.2f}, {m['ty_mm']:.2f}, {m['tz_mm']:.2f}) mm, "
                                    f"R {m['r_deg']:.2f} deg, PRJ {m['prj_px']:.2f} px")]
    sections = [("Original vs refined (Table 4, last row)", table_html(t)),
                ("Status and confidence of the refined poses", table_html(t_st))]
    if ov:
        sections.append(("Overlays (orange: original annotation; green: refined)",
                         "".join(f"<p>{html.escape(p.name)}</p>{_img_tag(p, p.name)}" for p in ov)))
    sections.append(("Timings", table_html(tt)))
    report = write_html(out / "report.html", opts.title + " (real frames)", info, sections, files)
    summary.update(report=str(report), table4_md=table_text(t), table5_md="", status_md=table_text(t_st),
                   files=[str(p) for p in files] + [str(report)])
    return summary
