"""Is an object's error on a suite clip a convergence problem or a rest of the cost? Per (clip, object):
the mean over initialisation seeds of the per-seed mean R (deg) and tz (mm), the spread of those
per-seed means across seeds (sample standard deviation), and the statuses.

A spread much smaller than the mean says every seed ends at the same pose: the cost's minimum is
off (a bias; refining from the exact GT ends there too), and more seeds or a wider capture cannot
lower it. A spread of the order of the mean says the seeds end in different places (capture).

    python bench/suite_seed_spread.py --rows bench/results/ycbv21/axis_hold_s62/rows/*.csv.gz \\
        --kind short --min-r-deg 0.3 --min-tz-mm 1.5 --out bench/results/ycbv21/seed_spread_s63

Only the (clip, object) pairs whose mean R or tz reaches the thresholds are listed, with every pair
of the objects that miss a target in the per-object means (``--kind``'s targets); rows of the
``using all`` variant from the paper's initial error.
"""
from __future__ import annotations

import argparse
import csv
import gzip
from collections import defaultdict
from pathlib import Path

import numpy as np


def read_rows(paths: list[Path]) -> list[dict]:
    rows = []
    for p in paths:
        with (gzip.open if p.suffix == ".gz" else open)(p, "rt", newline="") as fh:
            rows += [r for r in csv.DictReader(fh) if r["init"] == "paper" and r["variant"] == "using all"]
    return rows


def spread(rows: list[dict], kind: str) -> dict[tuple[str, int], dict]:
    """(clip, obj_id) -> per-seed means and their spread (R deg, tz mm), statuses, held_out flag."""
    by = defaultdict(lambda: defaultdict(list))
    meta: dict = {}
    for r in rows:
        if r["kind"] != kind:
            continue
        key = (r["clip"], int(r["obj_id"]))
        by[key][int(r["seed"])].append((float(r["r_deg"]), float(r["tz_mm"]), r["status"]))
        meta.setdefault(key, {"held_out_scene": r["held_out"] in ("1", "True", "true")})
    out = {}
    for key, seeds in by.items():
        r_s = np.array([np.mean([x[0] for x in v]) for v in seeds.values()])
        tz_s = np.array([np.mean([x[1] for x in v]) for v in seeds.values()])
        st = [x[2] for v in seeds.values() for x in v]
        out[key] = {"n_seeds": len(seeds), "r_deg": float(r_s.mean()), "r_sd": float(r_s.std(ddof=1)) if len(r_s) > 1 else np.nan,
                    "tz_mm": float(tz_s.mean()), "tz_sd": float(tz_s.std(ddof=1)) if len(tz_s) > 1 else np.nan,
                    "converged": float(np.mean([s == "converged" for s in st])), **meta[key]}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", nargs="+", type=Path, required=True)
    ap.add_argument("--kind", default="short")
    ap.add_argument("--min-r-deg", type=float, default=0.3)
    ap.add_argument("--min-tz-mm", type=float, default=1.5)
    ap.add_argument("--out", type=Path, required=True)
    args = ap.parse_args()
    from ycbvss.eval.tables import Row, Table, write_table

    sp = spread(read_rows(args.rows), args.kind)
    t = Table(columns=["seeds", "R (deg)", "R sd over seeds", "tz (mm)", "tz sd over seeds", "converged"],
              label_header="clip, object (* = held-out scene)",
              caption=(f"{args.kind} clips from the paper's initial error: per (clip, object) with mean R >= "
                       f"{args.min_r_deg} deg or tz >= {args.min_tz_mm} mm, the mean over seeds of the per-seed "
                       "mean error and the standard deviation of those per-seed means across seeds"))
    keep = sorted(k for k, v in sp.items() if v["r_deg"] >= args.min_r_deg or v["tz_mm"] >= args.min_tz_mm)
    for k in keep:
        v = sp[k]
        t.rows.append(Row(f"{k[0]}, object {k[1]}", [v["n_seeds"], v["r_deg"], v["r_sd"], v["tz_mm"], v["tz_sd"],
                                                      v["converged"]], mark=v["held_out_scene"]))
    if keep:
        ratio_r = [sp[k]["r_sd"] / sp[k]["r_deg"] for k in keep if sp[k]["r_deg"] >= args.min_r_deg]
        t.caption += (f"; {len(keep)} pairs, median (R sd / R) {np.nanmedian(ratio_r):.3f} over the "
                      f"{len(ratio_r)} with R >= {args.min_r_deg} deg")
    for p in write_table(t, args.out, "seed_spread"):
        print(p)


if __name__ == "__main__":
    main()
