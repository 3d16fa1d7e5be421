"""How much of a suite run's depth error is one scale per clip.

With free cameras a refined scene can come out uniformly too large or too small: every
object-to-camera translation times 1 + s (:mod:`ycbvss.refine.scene_scale`). For each clip (and
init, seed) of suite rows this fits that one s by least squares to the refined translations' errors
against the exact GT (``dx_mm, dy_mm, dz_mm`` of the rows; the GT translations from the suite's
``scene_gt.json``): s = sum(t_gt . d) / sum(|t_gt|^2) over the poses within FIT_MAX_MM. It reports s (in %), the mean signed depth
error, the mean |dz| of the poses, and the mean |dz| left once s is taken out (d - s t_gt).
A clip whose error is mostly its scale has a small remainder: the fault is then the scene's scale
(the contours' and the flow matches' apparent-size biases), not the single objects.

    python bench/suite_scene_scale.py --suite-root /tmp/suite/long2 \\
        --rows /tmp/runs/s76_long2_paper/rows.csv --out bench/results/ycbv21/s76/scale_long2
"""
from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np

from ycbvss.eval.tables import Row, Table, write_table
from ycbvss.io.bop import read_scene_gt
from ycbvss.pipeline.suite_run import read_rows


# poses whose translation is further off than this are left out of the fit (not of the means):
# one failed object would otherwise set the scene's scale
FIT_MAX_MM = 10.0


def gt_translations_mm(suite_root: Path, scene_id: int) -> dict[tuple[int, int], np.ndarray]:
    """(im_id, obj_id) -> the GT object-to-camera translation (3,) mm of one rendered suite scene."""
    gt = read_scene_gt(suite_root / "test" / f"{scene_id:06d}" / "scene_gt.json", scene_id)
    return {(im, inst.obj_id): inst.T_m2c[:3, 3] for im, insts in gt.items() for inst in insts}


def fit_scale(t_gt_mm: np.ndarray, d_mm: np.ndarray) -> float:
    """The s (unitless) of d ~ s t_gt by least squares: t_gt_mm, d_mm (N, 3) the GT translations
    and the refined-minus-GT errors, mm."""
    den = float((t_gt_mm * t_gt_mm).sum())
    return float((t_gt_mm * d_mm).sum() / den) if den > 0 else float("nan")


def clip_scale_rows(rows: list[dict], suite_root: Path) -> list[tuple[str, list]]:
    """Per (clip, init, seed): [poses, s (%), mean signed dz, mean |dz|, mean |dz| without s (mm)]."""
    groups = defaultdict(list)
    for r in rows:
        groups[(r["clip"], r["init"], int(r["seed"]), int(r["scene_id"]))].append(r)
    out, gts = [], {}
    for (clip, init, seed, sid), rs in sorted(groups.items()):
        if sid not in gts:
            gts[sid] = gt_translations_mm(suite_root, sid)
        keys = [(int(r["im_id"]), int(r["obj_id"])) for r in rs]
        t = np.array([gts[sid][k] for k in keys])
        d = np.array([[float(r["dx_mm"]), float(r["dy_mm"]), float(r["dz_mm"])] for r in rs])
        ok = np.isfinite(d).all(axis=1)
        fit = ok & (np.linalg.norm(np.where(ok[:, None], d, 0.0), axis=1) <= FIT_MAX_MM)
        s = fit_scale(t[fit], d[fit])
        rest = d[ok] - s * t[ok]
        out.append((f"{clip} / {init} / seed {seed}", [int(ok.sum()), 100.0 * s, float(d[ok, 2].mean()),
                                                      float(np.abs(d[ok, 2]).mean()), float(np.abs(rest[:, 2]).mean())]))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite-root", required=True, help="the rendered suite (test/<scene>/scene_gt.json)")
    ap.add_argument("--rows", nargs="+", required=True, help="rows.csv(.gz) of bench/suite_runs.py")
    ap.add_argument("--out", required=True, help="folder of scene_scale.md/.csv/.tex")
    a = ap.parse_args(argv)
    rows = [r for p in a.rows for r in read_rows(Path(p))]
    t = Table(columns=["poses", "scale s (%)", "signed dz (mm)", "|dz| (mm)", "|dz| without s (mm)"],
              label_header="clip / init / seed", digits=3,
              caption="One scale per clip: the refined translations' errors fitted as s times the GT translations "
                      "(least squares, poses more than 10 mm off left out of the fit); |dz| is the mean absolute depth error of the poses, before and after taking s out.")
    t.rows = [Row(label, vals) for label, vals in clip_scale_rows(rows, Path(a.suite_root))]
    for p in write_table(t, a.out, "scene_scale"):
        print(p)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
