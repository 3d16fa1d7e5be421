"""The turned-copy texture check (``refine/turn_check.py``) on validation-suite clips: silent
failures, capture range and accuracy with the check off, flagging only, and flagging + restart.

    python bench/suite_turn_check.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \\
        --scenes 4,5,8 --inits paper,prj2,prj10,prj15,prj20 --work /tmp/turn --out bench/results/ycbv21

Builds (or reuses) the suite scenes under ``--suite-root``, refines their short clips (``--kinds``)
from every init of ``--inits`` (``paper``, ``prj<N>``, ``add<N>``: see
:func:`ycbvss.pipeline.suite_run.initial_poses`) at ``--seeds``, once per mode of ``--modes``
(``off``: ``turn_check=False``; ``flag``: the defaults, ``turn_restart=False``; ``restart``:
``turn_restart=True``); runs
already done under ``--work/<mode>`` are reused. Writes ``turn_check.{md,csv,tex}`` (per mode and
init: poses, share refined to ADD < 2 mm, poses with ADD > 10 mm and how many of them were reported
``converged``, converged share, mean tz / R) and, for the last mode, the capture range against the
initial PRJ as ``capture_prj_turn.{md,csv,tex,png}`` (from the ``flag`` mode, the defaults, if run, else the last),
and per kind of clip the per-object means from the paper's init as ``objects_<kind>.{md,csv,tex}``.
``--options`` adds RefineOptions overrides (JSON) to every mode, e.g. ``'{"free_gauge": true}'``;
use a separate ``--work`` per option set (finished runs are reused by name).
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ycbvss.eval.tables import Row, Table, write_table
from ycbvss.pipeline.suite import build_suite, clips_of
from ycbvss.pipeline.suite_report import capture_png, capture_table, object_table
from ycbvss.pipeline.suite_run import Run, execute, read_rows

MODES = {"off": {"turn_check": False}, "flag": {"turn_restart": False}, "restart": {"turn_restart": True}}
COLUMNS = ["poses", "ADD<2mm", "ADD>10mm", "ADD>10mm converged (silent)", "converged", "tz (mm)", "R (deg)"]


def turn_table(by_mode: dict[str, list[dict]], inits: list[str], what: str) -> Table:
    """One row per (mode, init): columns :data:`COLUMNS` (shares in [0, 1], means over poses);
    ``what`` names the clips and seeds in the caption."""
    t = Table(columns=COLUMNS, label_header="mode / init", digits=3,
              caption=f"Turned-copy texture check on {what}: off / flag (the default) / flag + restart. "
                      "Silent = poses with ADD > 10 mm reported `converged`.")
    first = True
    for mode, rows in by_mode.items():
        for k, init in enumerate(inits):
            rs = [r for r in rows if r["init"] == init]
            if not rs:
                continue
            big = [r for r in rs if r["add_mm"] > 10.0]
            t.rows.append(Row(f"{mode} / {init}", [
                len(rs), float(np.mean([r["add_mm"] < 2.0 for r in rs])), len(big),
                sum(r["status"] == "converged" for r in big), float(np.mean([r["status"] == "converged" for r in rs])),
                float(np.mean([r["tz_mm"] for r in rs])), float(np.mean([r["r_deg"] for r in rs]))],
                rule_before=(k == 0 and not first)))
        first = False
    return t


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dataset", required=True, help="original YCB-Video root (models)")
    ap.add_argument("--suite-root", required=True, help="where the suite scenes are built / cached")
    ap.add_argument("--scenes", default="4,5,8")
    ap.add_argument("--kinds", default="short")
    ap.add_argument("--inits", default="paper,prj2,prj10,prj15,prj20")
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--modes", default="off,flag,restart", help=f"comma list of {', '.join(MODES)}")
    ap.add_argument("--work", required=True, help="per-mode run folders (rows.csv, done/)")
    ap.add_argument("--out", required=True, help="tables folder")
    ap.add_argument("--tag", default="", help="suffix of the table file names (e.g. _seed5)")
    ap.add_argument("--options", default="{}",
                    help='RefineOptions overrides for every mode, JSON (e.g. \'{"free_gauge": true}\')')
    a = ap.parse_args(argv)
    scenes = [int(s) for s in a.scenes.split(",")]
    inits = a.inits.split(",")
    seeds = [int(s) for s in a.seeds.split(",")]
    modes = a.modes.split(",")
    extra = json.loads(a.options)
    root = Path(a.suite_root)
    models, specs = build_suite(a.dataset, root, scene_ids=scenes)
    runs = [Run(c, init, s) for spec in specs for c in clips_of(spec, tuple(a.kinds.split(",")))
            for init in inits for s in seeds]
    by_mode = {}
    for mode in modes:
        rows_path = execute(runs, root, models, Path(a.work) / mode, {**MODES[mode], **extra})
        keys = {(r.clip.name, r.init, r.seed) for r in runs}
        by_mode[mode] = [r for r in read_rows(rows_path) if (r["clip"], r["init"], r["seed"]) in keys]
    out = Path(a.out)
    held = sorted({r.clip.name for r in runs if r.clip.held_out})
    what = (f"clips {', '.join(sorted({r.clip.name for r in runs}))}, seeds {a.seeds}"
            + (f" (held out: {', '.join(held)}" + (", and every seed >= 5)" if max(seeds) >= 5 else ")") if held else ""))
    write_table(turn_table(by_mode, inits, what), out, f"turn_check{a.tag}")
    cap = "flag" if "flag" in modes else modes[-1]
    for kind in a.kinds.split(","):     # per-object means from the paper's init (that mode)
        if any(r["kind"] == kind and r["init"] == "paper" for r in by_mode[cap]):
            write_table(object_table(by_mode[cap], models, kind), out, f"objects_{kind}{a.tag}")
    t, curves = capture_table(by_mode[cap])
    t.caption = (f"Capture range with the turned-copy check ({cap}), clips "
                 f"{', '.join(sorted({r.clip.name for r in runs}))}, seeds {a.seeds}: share of poses refined to ADD < 2 mm")
    if not curves:      # no capture-range init (prj<N>/add<N>) among --inits: no curve to draw
        return 0
    write_table(t, out, f"capture_prj_turn{a.tag}")
    capture_png(curves, out / f"capture_prj_turn{a.tag}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
