"""Run chosen validation-suite runs and write the suite report from every rows file given.

    python bench/suite_runs.py run --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \\
        --scenes 1,2,3 --kinds long --inits gt,paper --seeds 0 --work /tmp/suite/runs_long
    python bench/suite_runs.py run ... --scenes 1 --kinds long --inits paper --seeds 0 \\
        --variants "using all,w/o f_edge,w/o f_point,w/o f_t" --work /tmp/suite/runs_long
    python bench/suite_runs.py report --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \\
        --rows /tmp/suite/runs_long/rows.csv /tmp/suite/runs_sm/rows.csv --out bench/results/ycbv21

``run`` builds (or reuses) the scenes under ``--suite-root`` and refines every clip of ``--kinds`` x
``--inits`` x ``--seeds`` x ``--variants`` with the default RefineOptions (``--options`` JSON adds
overrides); finished runs under ``--work`` are reused (one process per work folder). It is the
subset of ``ycbvss validate --suite ycbv21`` one chooses, e.g. the ablation on one long clip only.
``report`` writes what :func:`ycbvss.pipeline.suite_report.write_report` writes (per-object,
held-out, bias, status, coverage, ablation tables; objects < 10 % visible apart) and prints the
per-axis sigma calibration factors that 2 sigma (with the systematic floor) needs to cover 90 % of
the development poses per baseline group (narrow: short clips, medium, wide: long), with the coverage they and the
current ones give on
the development and the held-out poses.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ycbvss.pipeline.options import read_options_arg
from ycbvss.pipeline.suite import build_suite, clips_of, suite_models
from ycbvss.pipeline.suite_report import KIND_GROUP, SIGMA_AXES, row_sigmas, split_visible, visibility, write_report
from ycbvss.pipeline.suite_run import Run, execute, read_rows
from ycbvss.refine.confidence import BASELINE_GROUPS, sigma_floor, sigma_scale, total_sigma


def _factor_for_90(rows: list[dict], axis: int, floor: float, k: float) -> float:
    """The factor f on an axis' raw covariance sigma (as the rows hold it) for which
    k * sqrt((f sigma)^2 + floor^2) covers 90 % of ``rows`` (bisection; 0 when the floor alone
    covers them)."""
    e, s = SIGMA_AXES[axis]
    err = np.array([r[e] for r in rows], float)
    raw = np.array([r[s] for r in rows], float)
    ok = np.isfinite(err) & np.isfinite(raw)
    share = lambda f: float(np.mean(err[ok] <= k * total_sigma(f * raw[ok], floor)))
    if not ok.any() or share(0.0) >= 0.9:
        return 0.0
    lo, hi = 0.0, 1.0
    while share(hi) < 0.9 and hi < 1e4:
        hi *= 2
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if share(mid) < 0.9 else (lo, mid)
    return hi


def _covered_share(rows: list[dict], factors: tuple, k: float) -> list[float]:
    """Per axis: share of ``rows`` within k sigma, sigma = factors x raw sigma + the floor."""
    if not rows:
        return [float("nan")] * len(SIGMA_AXES)
    err = np.array([[r[e] for e, _ in SIGMA_AXES] for r in rows], float)
    sig = np.array([row_sigmas(r, True, factors=factors) for r in rows], float)
    ok = np.isfinite(err) & np.isfinite(sig)
    return [float(np.mean(err[ok[:, a], a] <= k * sig[ok[:, a], a])) for a in range(len(SIGMA_AXES))]


def sigma_fit(rows: list[dict], k: float = 2.0) -> dict:
    """Per baseline group (narrow: short clips, medium, wide: long clips): the per-axis factors on the raw covariance sigmas that, with the
    systematic floor of :func:`ycbvss.refine.confidence.sigma_floor` added in quadrature, make
    ``k`` sigma cover 90 % of the development poses (paper init, all terms), and the coverage of the
    current and of those factors on the development and held-out poses."""
    rows = [r for r in rows if r["init"] == "paper" and r["variant"] == "using all"]
    out = {}
    for g in BASELINE_GROUPS:
        sel = [r for r in rows if KIND_GROUP[r["kind"]] == g]
        dev = [r for r in sel if not r["held_out"]]
        ho = [r for r in sel if r["held_out"]]
        if not dev:
            continue
        fit = [_factor_for_90(dev, a, sigma_floor(g)[a], k) for a in range(len(SIGMA_AXES))]
        rec = {"fit": fit, "current": list(sigma_scale(g)), "floor": list(sigma_floor(g)),
               "n_dev": len(dev), "n_held_out": len(ho)}
        for lab, rs in (("dev", dev), ("held_out", ho)):
            rec[f"coverage_current_{lab}"] = _covered_share(rs, tuple(sigma_scale(g)), k)
            rec[f"coverage_fit_{lab}"] = _covered_share(rs, tuple(fit), k)
        out[g] = rec
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("what", choices=("run", "report"))
    ap.add_argument("--dataset", required=True, help="YCB-Video root (or BOP root) with the 21 models")
    ap.add_argument("--suite-root", required=True)
    ap.add_argument("--suite", default="ycbv21", help="ycbv21, ycbv21-fresh (test scenes 31-36), ycbv21-fresh2 (test scenes 41-46, sealed until session 75), ycbv21-fresh3 (sealed test scenes 51-56), ycbv21-long2 (long test scenes 61-63, sealed until session 83), ycbv21-long3 (long test scenes 64-66, sealed until session 85), ycbv21-long4 (sealed long test scenes 67-69) or ycbv21-ci")
    ap.add_argument("--scenes", default="1,2,3,4,5,6,7,8,9")
    ap.add_argument("--kinds", default="short,medium,long")
    ap.add_argument("--inits", default="paper")
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--variants", default="using all")
    ap.add_argument("--options", default=None, help="RefineOptions overrides: a JSON object, @FILE or FILE.json "
                                                    "(checked as `ycbvss refine --options` checks it)")
    ap.add_argument("--work", help="run: the folder of rows.csv and the done markers")
    ap.add_argument("--rows", nargs="*", default=[], help="report: rows.csv files (later ones append)")
    ap.add_argument("--out", help="report: the table folder")
    a = ap.parse_args(argv)
    root = Path(a.suite_root)
    scenes = [int(x) for x in a.scenes.split(",")]
    if a.what == "run":
        if not a.work:
            ap.error("run needs --work")
        opts_kw = read_options_arg(a.options)          # checked before the suite is built
        models, specs = build_suite(a.dataset, root, a.suite, scene_ids=scenes)
        runs = [Run(c, i, int(s), v) for sp in specs for c in clips_of(sp, a.kinds.split(","))
                for i in a.inits.split(",") for s in a.seeds.split(",") for v in a.variants.split(",")]
        print(f"{len(runs)} runs", flush=True)
        execute(runs, root, models, Path(a.work), opts_kw)
        return 0
    if not a.out or not a.rows:
        ap.error("report needs --rows and --out")
    rows = [r for p in a.rows for r in read_rows(Path(p))]
    models = suite_models(a.dataset, root)
    vis = visibility(root, scenes)
    for name, p in write_report(rows, models, Path(a.out), vis).items():
        print(f"{name}: {p}")
    seen, _ = split_visible(rows, vis)
    for g, rec in sigma_fit(seen).items():
        print(f"sigma {g}: {rec['n_dev']} dev / {rec['n_held_out']} held-out poses; factors fitted "
              f"{[round(x, 2) for x in rec['fit']]} (current {list(rec['current'])}, floor {list(rec['floor'])})")
        for key in ("coverage_current_dev", "coverage_current_held_out", "coverage_fit_dev", "coverage_fit_held_out"):
            print(f"  {key}: {[round(x, 3) for x in rec[key]]}")
    return 0


if __name__ == "__main__":
    from ycbvss.errors import YcbvssError
    try:
        sys.exit(main())
    except YcbvssError as e:
        sys.exit(f"suite_runs.py: {e}")
