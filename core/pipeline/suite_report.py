"""Tables and curves of a validation-suite run (rows from :mod:`ycbvss.pipeline.suite_run`).

Every table is written as Markdown, CSV and LaTeX; values that miss a target are bold.

- ``objects_<kind>``: per object mean tx, ty, tz (mm), R (deg), PRJ (px) from the paper's initial
  error, all runs and the held-out runs (held-out scenes or seeds) separately;
- ``bias_<kind>``: per object mean error when refinement starts from the exact GT;
- ``coverage``: per axis, the fraction of poses whose error is within 2 sigma (reported sigma);
- ``status``: status counts, how often ``converged`` holds, and the flagged share of bad poses;
- ``capture``: fraction of poses refined to ADD < 2 mm against the initial mean ADD (+ PNG);
- ``ablation``: the paper's Table 5 on the long clips.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..eval.tables import ERROR_COLS, ERROR_HEADERS, ERROR_LATEX, Row, Table, write_table
from ..io.atomic import atomic_path, read_json
from ..refine.confidence import sigma_floor, sigma_scale, total_sigma, unsettled_sigma_t_mm
from ..viz import pyplot
from .pose_sets import PAPER_TABLE5

TARGETS = {"long": (0.25, 0.25, 0.8, 0.2, 0.4), "medium": (0.25, 0.25, 0.8, 0.2, 0.4),
           "short": (0.3, 0.3, 1.5, 0.3, 0.5)}
BIAS_TARGETS = (0.1, 0.1, 0.3, 0.05)         # tx, ty, tz (mm), R (deg), long clips, from the exact GT
PAPER_ALL = dict(PAPER_TABLE5)["using all"]
MIN_VISIB = 0.1
SIGMA_AXES = (("tx_mm", "sigma_tx_mm"), ("ty_mm", "sigma_ty_mm"), ("tz_mm", "sigma_tz_mm"), ("r_deg", "sigma_r_deg"))


def _sel(rows: list[dict], **kw) -> list[dict]:
    return [r for r in rows if all(r[k] == v for k, v in kw.items())]


def _mean(rows: list[dict], col: str) -> float:
    v = np.array([r[col] for r in rows], float)
    v = v[np.isfinite(v)]
    return float(v.mean()) if len(v) else float("nan")


def _names(models: dict) -> dict:
    return {o: (m.name or f"obj_{o:06d}") for o, m in models.items()}


def object_table(rows: list[dict], models: dict, kind: str, held_out_only: bool = False) -> Table:
    """Per-object means over the poses of ``kind`` clips refined from the paper's initial error."""
    rs = [r for r in _sel(rows, kind=kind, init="paper", variant="using all") if r["held_out"] or not held_out_only]
    tgt = TARGETS[kind]
    names = _names(models)
    t = Table(columns=[*ERROR_HEADERS, "poses", "ADD init (mm)"], label_header="object",
              latex_columns=[*ERROR_LATEX, "poses", "ADD init"],
              caption=(f"{kind} clips{' (held-out scenes/seeds only)' if held_out_only else ''}: mean errors "
                       f"from the paper's initial error; bold = misses the target "
                       f"(tx,ty <= {tgt[0]} mm, tz <= {tgt[2]} mm, R <= {tgt[3]} deg, PRJ <= {tgt[4]} px); "
                       f"* = textureless object (assets manifest)"))
    for o in sorted({r["obj_id"] for r in rs}):
        ro = [r for r in rs if r["obj_id"] == o]
        vals = [_mean(ro, c) for c in ERROR_COLS]
        t.rows.append(Row(names.get(o, str(o)), vals + [len(ro), _mean(ro, "init_add_mm")],
                          mark=bool(models[o].textureless),
                          bold=[not (v <= g) for v, g in zip(vals, tgt)] + [False, False]))
    if rs:
        per_obj = np.array([[_mean([r for r in rs if r["obj_id"] == o], c) for c in ERROR_COLS]
                            for o in sorted({r["obj_id"] for r in rs})])
        allv = list(np.nanmean(per_obj, axis=0))
        t.rows.append(Row("all (mean over objects)", allv + [len(rs), _mean(rs, "init_add_mm")],
                          rule_before=True, bold=[False] * 7))
        t.rows.append(Row("paper (Li et al.) all", list(PAPER_ALL) + [None, None], bold=[False] * 7))
    return t


def bias_table(rows: list[dict], models: dict, kind: str) -> Table:
    """Per-object mean |error| when refinement starts from the exact GT."""
    rs = _sel(rows, kind=kind, init="gt", variant="using all")
    names = _names(models)
    t = Table(columns=["tx (mm)", "ty (mm)", "tz (mm)", "R (deg)", "max |t| (mm)", "poses"], label_header="object",
              caption=(f"{kind} clips, refinement started from the exact GT: mean error per object; "
                       f"bold = above the bias bound (lateral 0.1 mm, depth 0.3 mm, R 0.05 deg); "
                       f"* = textureless object (assets manifest)"),
              digits=3)
    for o in sorted({r["obj_id"] for r in rs}):
        ro = [r for r in rs if r["obj_id"] == o]
        vals = [_mean(ro, c) for c in ("tx_mm", "ty_mm", "tz_mm", "r_deg")]
        mx = float(max(max(r["tx_mm"], r["ty_mm"], r["tz_mm"]) for r in ro))
        t.rows.append(Row(names.get(o, str(o)), vals + [mx, len(ro)], mark=bool(models[o].textureless),
                          bold=[not (v <= g) for v, g in zip(vals, BIAS_TARGETS)] + [False, False]))
    return t


KIND_GROUP = {"short": "narrow", "medium": "medium", "long": "wide"}   # suite clip kind -> baseline group


def _scale_of(r: dict, calibrated: bool) -> tuple:
    """The calibration factors the refiner applies to a row's clip (its baseline group's: short
    clips, 6-7 deg, are narrow bundles, medium 20 deg medium, long 60 deg wide; 1 uncalibrated)."""
    return sigma_scale(KIND_GROUP[r["kind"]]) if calibrated else (1.0, 1.0, 1.0, 1.0)


def _floor_of(r: dict, calibrated: bool) -> tuple:
    """The systematic sigma floor the refiner adds to a row's clip (its baseline group's; 0
    uncalibrated)."""
    return sigma_floor(KIND_GROUP[r["kind"]]) if calibrated else (0.0, 0.0, 0.0, 0.0)


def row_sigmas(r: dict, calibrated: bool = True, factors: tuple | None = None) -> np.ndarray:
    """A row's per-axis sigmas (tx, ty, tz mm, R deg): its raw covariance sigmas times the
    calibration factors (``factors`` instead of the refiner's when given), plus, when calibrated,
    the systematic floor in quadrature and, for a pose that is not ``converged``, the widening of
    :func:`ycbvss.refine.confidence.unsettled_sigma_t_mm` by its ``sigma_add_mm`` (rows written
    before session 78 lack that column and keep the unwidened sigma) -- what the refiner reports."""
    f = np.asarray(factors if factors is not None else _scale_of(r, calibrated), float)
    raw = np.array([r[s] for _, s in SIGMA_AXES], float)
    out = total_sigma(f * raw, _floor_of(r, calibrated))
    sa = float(r.get("sigma_add_mm", float("nan")))
    if calibrated and r.get("status") != "converged" and np.isfinite(sa):
        out[:3] = unsettled_sigma_t_mm(out[:3], sa)
    return out


def coverage(rows: list[dict], k: float = 2.0, calibrated: bool = False, converged_only: bool = False) -> dict:
    """Per axis: share of poses with |error| <= k sigma (sigma = the covariance sigma before
    calibration, as the rows hold it; with ``calibrated`` what the refiner reports, see
    :func:`row_sigmas`), over poses refined from the paper's initial error (only status
    ``converged`` ones with ``converged_only``); plus the factor on sigma that would make 90 %
    covered."""
    rs = [r for r in _sel(rows, init="paper", variant="using all") if not converged_only or r["status"] == "converged"]
    sigs = np.array([row_sigmas(r, calibrated) for r in rs], float).reshape(-1, len(SIGMA_AXES))
    out = {}
    for a, (e, _) in enumerate(SIGMA_AXES):
        err = np.array([r[e] for r in rs], float)
        sig = sigs[:, a]
        ok = np.isfinite(err) & np.isfinite(sig) & (sig > 0)
        if not ok.any():
            out[e] = {"coverage": float("nan"), "n": 0, "scale_for_90": float("nan")}
            continue
        ratio = err[ok] / sig[ok]
        out[e] = {"coverage": float(np.mean(ratio <= k)), "n": int(ok.sum()),
                  "scale_for_90": float(np.quantile(ratio, 0.9) / k)}
    return out


def coverage_table(rows: list[dict]) -> Table:
    """Coverage of the calibrated sigmas on every pose and on the converged ones, development and
    held-out runs apart, over all clips and per clip kind; the raw covariance sigmas' coverage
    beside."""
    t = Table(columns=["dev: all", "dev: converged", "held-out: all", "held-out: converged", "raw sigma: all",
                       "poses"], label_header="axis", digits=3,
              caption="Share of refined poses whose true error is within 2 calibrated sigma (target >= 0.90); "
                      "sigma = covariance sigma x factors fitted on the development poses, plus the systematic "
                      "floor measured from the exact GT in quadrature (refine.confidence)")
    kinds = [k for k in ("short", "medium", "long") if any(r["kind"] == k for r in rows)]
    for kind in [None] + (kinds if len(kinds) > 1 else []):
        rk = [r for r in rows if kind is None or r["kind"] == kind]
        dev = [r for r in rk if not r["held_out"]]
        ho = [r for r in rk if r["held_out"]]
        cols = [coverage(dev, calibrated=True), coverage(dev, calibrated=True, converged_only=True),
                coverage(ho, calibrated=True), coverage(ho, calibrated=True, converged_only=True), coverage(rk)]
        for e, _ in SIGMA_AXES:
            vals = [c[e]["coverage"] for c in cols]
            t.rows.append(Row(e if kind is None else f"{e} ({kind})", vals + [int(cols[-1][e]["n"])],
                              bold=[not (v >= 0.9) for v in vals[:4]] + [False, False]))
    return t


def status_table(rows: list[dict]) -> Table:
    """Per clip kind: status counts, share converged, and for poses with ADD > 10 mm the share
    flagged (uncertain/failed) or covered by their sigma."""
    t = Table(columns=["converged", "uncertain", "failed", "share converged", "ADD>10mm", "of those flagged or covered",
                       "ADD<=2mm among converged"], label_header="clips", digits=3,
              caption="Status of refined poses (paper's initial error, all terms)")
    for kind in ("short", "medium", "long"):
        rs = _sel(rows, kind=kind, init="paper", variant="using all")
        if not rs:
            continue
        c = {s: sum(r["status"] == s for r in rs) for s in ("converged", "uncertain", "failed")}
        bad = [r for r in rs if r["add_mm"] > 10]
        ok_bad = [r for r in bad if r["status"] != "converged" or _covered(r)]
        conv = [r for r in rs if r["status"] == "converged"]
        t.rows.append(Row(kind, [c["converged"], c["uncertain"], c["failed"],
                                 c["converged"] / len(rs), len(bad),
                                 (len(ok_bad) / len(bad)) if bad else float("nan"),
                                 (sum(r["add_mm"] <= 2 for r in conv) / len(conv)) if conv else float("nan")]))
    return t


def _covered(r: dict, k: float = 2.0) -> bool:
    """The pose's error is within k calibrated sigmas on every axis."""
    sig = row_sigmas(r)
    return all(np.isfinite(sg) and r[e] <= k * sg for (e, _), sg in zip(SIGMA_AXES, sig))


def _capture_axis(init: str) -> tuple[str, float] | None:
    """(axis, sort key) of a capture-range level: ("add", mm) for add<N>, ("prj", px) for prj<N>;
    the paper's init (22.1 mm, 5.2 px) lies on both curves."""
    if init.startswith("add"):
        return "add", float(init[3:])
    if init.startswith("prj"):
        return "prj", float(init[3:])
    return None


def capture_table(rows: list[dict]) -> tuple[Table, dict]:
    """Share of poses refined to ADD < 2 mm per init level (mean initial ADD, PRJ), per clip kind.

    Two curves per kind: against the initial mean ADD (levels ``add<N>``, PRJ growing with it) and
    against the initial mean PRJ at the paper init's depth error (levels ``prj<N>``); the paper's init is on both.
    Returns (table, curves) with curves[axis][kind] = [(init ADD mm, init PRJ px, share), ...]."""
    clips = {r["clip"] for r in rows if _capture_axis(r["init"])}
    rows = [r for r in rows if r["clip"] in clips]          # the clips the levels were run on
    inits = {r["init"] for r in rows if _capture_axis(r["init"]) or r["init"] == "paper"}
    levels = sorted(inits, key=lambda s: (0, 22.1) if s == "paper" else
                    (0 if _capture_axis(s)[0] == "add" else 1, _capture_axis(s)[1]))
    kinds = [k for k in ("short", "medium", "long") if any(r["kind"] == k for r in rows)]
    t = Table(columns=["init ADD (mm)", "init PRJ (px)"] + [f"{k}: ADD<2mm" for k in kinds], label_header="init",
              caption="Capture range: share of poses refined to ADD < 2 mm (clips: " + ", ".join(sorted(clips)) + ")",
              digits=3)
    axes = sorted({_capture_axis(lv)[0] for lv in levels if lv != "paper"})
    curves: dict = {a: {k: [] for k in kinds} for a in axes}
    for lv in levels:
        rs = _sel(rows, init=lv, variant="using all")
        vals = []
        for k in kinds:
            rk = [r for r in rs if r["kind"] == k]
            frac = float(np.mean([r["add_mm"] < 2 for r in rk])) if rk else float("nan")
            vals.append(frac)
            if rk:
                for a in (axes if lv == "paper" else [_capture_axis(lv)[0]]):
                    curves[a][k].append((_mean(rk, "init_add_mm"), _mean(rk, "init_prj_px"), frac))
        t.rows.append(Row(lv, [_mean(rs, "init_add_mm"), _mean(rs, "init_prj_px")] + vals))
    return t, curves


def capture_png(curves: dict, path: Path) -> Path:
    """One panel per axis: share refined to ADD < 2 mm against the initial mean ADD (mm; PRJ grows
    with it) and, if measured, against the initial mean PRJ (px; the paper init's depth error)."""
    plt = pyplot()

    axes = [a for a in ("add", "prj") if a in curves]
    fig, axs = plt.subplots(1, len(axes), figsize=(5.5 * len(axes), 3.6), squeeze=False)
    for ax, a in zip(axs[0], axes):
        col = 0 if a == "add" else 1
        for k, pts in curves[a].items():
            if pts:
                pts = sorted(pts, key=lambda p: p[col])
                ax.plot([p[col] for p in pts], [p[2] for p in pts], "o-", label=f"{k} clips")
        ax.set_xlabel("initial mean ADD (mm)  [PRJ = ADD x 5.2/22.1 px]" if a == "add"
                      else "initial mean PRJ (px)  [depth error of the paper's init]")
        ax.set_ylabel("share refined to ADD < 2 mm")
        ax.set_ylim(0, 1.02)
        ax.grid(alpha=0.3)
        ax.legend()
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=120)
    plt.close(fig)
    return path


def ablation_table(rows: list[dict], kind: str = "long") -> Table:
    """Mean over objects per variant (paper Table 5 layout), the paper's values beside."""
    t = Table(columns=list(ERROR_HEADERS), label_header="variant", latex_columns=list(ERROR_LATEX),
              caption=f"Ablation on the {kind} clips (mean over objects; keyframes); best per column bold")
    vals = {}
    for v in ("w/o f_edge", "w/o f_point", "w/o f_t", "using all"):
        rs = _sel(rows, kind=kind, init="paper", variant=v)
        if not rs:
            continue
        if v == "using all":     # the ablations run on the keyframes: compare on the same frames
            ab = _sel(rows, kind=kind, init="paper", variant="w/o f_t")
            kf = {(r["clip"], r["seed"], r["im_id"]) for r in ab}
            rs = [r for r in rs if (r["clip"], r["seed"], r["im_id"]) in kf] or rs
        objs = sorted({r["obj_id"] for r in rs})
        vals[v] = [float(np.nanmean([_mean([r for r in rs if r["obj_id"] == o], c) for o in objs])) for c in ERROR_COLS]
    best = [min((vals[v][c] for v in vals), default=math.nan) for c in range(5)]
    for v, vv in vals.items():
        t.rows.append(Row(v, vv, bold=[abs(x - b) < 1e-12 for x, b in zip(vv, best)]))
    for v, pv in PAPER_TABLE5:
        t.rows.append(Row(f"paper: {v}", list(pv), rule_before=(v == "w/o f_edge")))
    return t


def visibility(root: Path, scene_ids) -> dict:
    """{(scene_id, im_id, obj_id): visib_fract} from the suite dataset's scene_gt_info.json files."""
    out = {}
    for sid in scene_ids:
        sdir = Path(root) / "test" / f"{sid:06d}"
        if not (sdir / "scene_gt_info.json").is_file():
            continue
        info = read_json(sdir / "scene_gt_info.json", "scene_gt_info.json")
        gt = read_json(sdir / "scene_gt.json", "scene_gt.json")
        for im, lst in info.items():
            for g, inf in zip(gt[im], lst):
                out[(int(sid), int(im), int(g["obj_id"]))] = float(inf["visib_fract"])
    return out


def split_visible(rows: list[dict], visib: dict, min_visib: float = MIN_VISIB) -> tuple[list[dict], list[dict]]:
    """(poses whose GT visible fraction is >= ``min_visib``, the others) -- BOP evaluates only the
    former; an object hidden in an image can only be placed by the scene consistency."""
    seen, hidden = [], []
    for r in rows:
        (seen if visib.get((r["scene_id"], r["im_id"], r["obj_id"]), 1.0) >= min_visib else hidden).append(r)
    return seen, hidden


def write_report(rows: list[dict], models: dict, out: Path, visib: dict | None = None) -> dict[str, Path]:
    """Write every table (md/csv/tex) and the capture-range PNG into ``out``; returns the paths.
    With ``visib`` (see :func:`visibility`) poses of objects less than 10 % visible are left out of
    the accuracy tables (BOP's rule) and counted in ``hidden.md``."""
    out = Path(out)
    paths: dict[str, Path] = {}
    if visib:
        rows, hidden = split_visible(rows, visib)
        t = status_table(hidden)
        t.caption = f"Status of the {len(hidden)} poses of objects < {MIN_VISIB:.0%} visible (left out of the accuracy tables)"
        paths["hidden"] = write_table(t, out, "hidden")[0]
    kinds = [k for k in ("short", "medium", "long") if any(r["kind"] == k for r in rows)]
    for k in kinds:
        if _sel(rows, kind=k, init="paper", variant="using all"):
            paths[f"objects_{k}"] = write_table(object_table(rows, models, k), out, f"objects_{k}")[0]
            if any(r["held_out"] for r in _sel(rows, kind=k, init="paper")):
                paths[f"objects_{k}_heldout"] = write_table(object_table(rows, models, k, True), out,
                                                            f"objects_{k}_heldout")[0]
        if _sel(rows, kind=k, init="gt"):
            paths[f"bias_{k}"] = write_table(bias_table(rows, models, k), out, f"bias_{k}")[0]
    paths["coverage"] = write_table(coverage_table(rows), out, "coverage")[0]
    paths["status"] = write_table(status_table(rows), out, "status")[0]
    if any(_capture_axis(r["init"]) for r in rows):
        t, curves = capture_table(rows)
        paths["capture"] = write_table(t, out, "capture")[0]
        paths["capture_png"] = capture_png(curves, out / "capture.png")
    for k in kinds:
        if len({r["variant"] for r in _sel(rows, kind=k)}) > 1:
            paths[f"ablation_{k}"] = write_table(ablation_table(rows, k), out, f"ablation_{k}")[0]
    return paths
