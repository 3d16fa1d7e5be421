"""Where the long clips' bias from the exact GT comes from: the same clips refined from the exact
GT under different conditions, side by side per object.

Each ``--rows LABEL=PATH`` is a rows file of ``bench/suite_runs.py run ... --inits gt`` (long clips)
with some ``--options``; typically

- ``free cameras`` (defaults): cameras and objects refined, as on real data;
- ``known cameras`` (``{"fix_cameras": true}``): the cameras held at the exact GT, objects refined;
- ``accurate f_t`` (``{"flow_prior": "residual"}``): f_t's image-to-image flow started from the
  motion the current estimate predicts (bench_temporal_flow.py: keyframe pairs 25 frames apart lose
  their systematic error, slope -1.4 -> 0.0 px/px).

If the bias disappears with known cameras, it is a scene-wide move of the cameras against the
objects (a scale of the scene: the objects' apparent size is all that fixes it when the cameras are
free), not a per-object fault of the cost. Per object and condition: signed mean depth change dz
(refined minus GT, mm), mean lateral |t| (the larger of tx, ty, mm), mean R (deg); then, per
condition, the objects within the bias bound (0.1 mm lateral, 0.3 mm depth, 0.05 deg) and per clip
the mean signed dz.

    python bench/suite_bias_sources.py --rows "free cameras=/tmp/b/free/rows.csv" \
        --rows "known cameras=/tmp/b/fix/rows.csv" --rows "accurate f_t=/tmp/b/res/rows.csv" \
        --dataset ../shared/data/ycbv --suite-root /tmp/suite/full --out bench/results/ycbv21
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

BOUND = (0.1, 0.3, 0.05)        # lateral mm, depth mm, R deg (the bias bound on the long clips)


def per_object(rows: list[dict]) -> dict:
    """obj_id -> (clip, signed dz mm, lateral mm, R deg, |dz| mm) means over the object's poses."""
    out: dict = {}
    for o in sorted({r["obj_id"] for r in rows}):
        ro = [r for r in rows if r["obj_id"] == o]
        out[o] = (ro[0]["clip"], float(np.mean([r["dz_mm"] for r in ro])),
                  float(max(np.mean([r["tx_mm"] for r in ro]), np.mean([r["ty_mm"] for r in ro]))),
                  float(np.mean([r["r_deg"] for r in ro])), float(np.mean([r["tz_mm"] for r in ro])))
    return out


def within_bound(v: tuple) -> bool:
    """An object's means (as :func:`per_object`) within the bias bound."""
    return v[2] <= BOUND[0] and v[4] <= BOUND[1] and v[3] <= BOUND[2]


def main(argv: list[str] | None = None) -> int:
    from ycbvss.eval.tables import Row, Table, write_table
    from ycbvss.pipeline.suite import suite_models
    from ycbvss.pipeline.suite_run import read_rows

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", action="append", required=True, help="LABEL=PATH (repeat)")
    ap.add_argument("--dataset", required=True, help="YCB-Video root (or BOP root) with the 21 models (object names)")
    ap.add_argument("--suite-root", required=True, help="the suite's root (its models/ are read)")
    ap.add_argument("--out", required=True)
    ap.add_argument("--name", default="bias_sources")
    a = ap.parse_args(argv)
    conds = []
    for spec in a.rows:
        label, _, path = spec.partition("=")
        rs = [r for r in read_rows(Path(path)) if r["init"] == "gt" and r["kind"] == "long"
              and r["variant"] == "using all"]
        if not rs:
            raise SystemExit(f"error: {path}: no long-clip rows refined from the exact GT")
        conds.append((label, per_object(rs)))
    models = suite_models(a.dataset, Path(a.suite_root))
    objs = sorted(set().union(*(c[1].keys() for c in conds)))
    cols = [f"{lab}: {c}" for lab, _ in conds for c in ("dz (mm)", "lateral (mm)", "R (deg)")]
    t = Table(columns=cols, label_header="object", digits=3,
              caption=("Long clips refined from the exact GT under each condition: per object the signed mean "
                       "depth change dz (refined - GT), the mean lateral error (larger of tx, ty) and mean R; "
                       "bold = above the bias bound (|dz| mean 0.3 mm, lateral 0.1 mm, R 0.05 deg)"))
    for o in objs:
        vals, bold = [], []
        for _, po in conds:
            v = po.get(o)
            vals += [v[1], v[2], v[3]] if v else [None, None, None]
            bold += [bool(v and v[4] > BOUND[1]), bool(v and v[2] > BOUND[0]), bool(v and v[3] > BOUND[2])]
        name = models[o].name if o in models else str(o)
        t.rows.append(Row(name, vals, bold=bold))
    summ = []
    for _, po in conds:
        summ += [float(sum(within_bound(v) for v in po.values())), float(sum(v[4] <= BOUND[1] for v in po.values())),
                 float(sum(v[3] <= BOUND[2] for v in po.values()))]
    t.rows.append(Row("objects within: all bounds / depth / R", summ, rule_before=True, bold=[False] * len(summ)))
    for clip in sorted({v[0] for _, po in conds for v in po.values()}):
        vals = []
        for _, po in conds:
            d = [v[1] for v in po.values() if v[0] == clip]
            vals += [float(np.mean(d)) if d else None, None, None]
        t.rows.append(Row(f"{clip}: mean signed dz", vals, bold=[False] * len(vals)))
    for p in write_table(t, Path(a.out), a.name):
        print(p)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
