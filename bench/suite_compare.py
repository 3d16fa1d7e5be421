"""One comparison table (Markdown, CSV, LaTeX) of suite runs: per labelled selection of rows, the
means over clip-objects of tx, ty, tz, signed dz (refined minus GT depth, mm), R, PRJ, and over
poses the ADD < 2 mm share, the poses with ADD > 10 mm, the converged share.

    python bench/suite_compare.py --out bench/results/ycbv21/template_shading --name runs \\
        --caption "..." \\
        --run "long-1 paper, default=/tmp/base/rows.csv:clip=long-1,init=paper,seed=0" \\
        --run "long-1 paper, template_shading=/tmp/sh/rows.csv:clip=long-1,init=paper,seed=0" \\
        --run "short dev, exact GT=/tmp/base/rows.csv:kind=short,init=gt,scene_id=1|2|4|5|6|7"

A selection is ``label=rows.csv[:field=value|value,...]``: rows whose field is one of the values.
Rows come from ``bench/suite_runs.py run`` (``rows.csv`` under its ``--work``; a gzipped copy reads as well).
"""
from __future__ import annotations

import argparse
import csv
import gzip
from collections import defaultdict
from pathlib import Path

import numpy as np


def parse_run(spec: str) -> tuple[str, Path, dict[str, set[str]]]:
    """``label=path[:k=v|v,k=v]`` -> (label, path, {field: allowed values})."""
    label, _, rest = spec.partition("=")
    path, _, flt = rest.partition(":")
    filters: dict[str, set[str]] = {}
    for part in filter(None, flt.split(",")):
        k, _, v = part.partition("=")
        filters[k.strip()] = set(v.split("|"))
    return label.strip(), Path(path), filters


def select(path: Path, filters: dict[str, set[str]]) -> list[dict]:
    """The rows of ``path`` (``rows.csv`` or ``rows.csv.gz``) whose fields match ``filters``."""
    with (gzip.open if path.suffix == ".gz" else open)(path, "rt", newline="") as fh:
        return [r for r in csv.DictReader(fh) if all(r.get(k) in v for k, v in filters.items())]


def summarise(rows: list[dict]) -> list[float]:
    """[tx, ty, tz, signed dz, R, PRJ] means over clip-objects, then ADD < 2 share, ADD > 10 count,
    converged share, poses."""
    per = defaultdict(list)
    for r in rows:
        per[(r["clip"], r["obj_id"])].append([float(r[c]) for c in ("tx_mm", "ty_mm", "tz_mm", "dz_mm", "r_deg", "prj_px")])
    m = np.array([np.mean(v, axis=0) for v in per.values()])
    add = np.array([float(r["add_mm"]) for r in rows])
    conv = float(np.mean([r["status"] == "converged" for r in rows]))
    return [float(x) for x in m.mean(axis=0)] + [float(np.mean(add < 2.0)), int(np.sum(add > 10.0)), conv, len(rows)]


def main() -> None:
    from ycbvss.eval.tables import Row, Table, write_table

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", action="append", required=True, help="label=rows.csv[:field=v|v,...]")
    ap.add_argument("--out", required=True)
    ap.add_argument("--name", required=True)
    ap.add_argument("--caption", default="")
    a = ap.parse_args()
    t = Table(["tx (mm)", "ty (mm)", "tz (mm)", "signed dz (mm)", "R (deg)", "PRJ (px)", "ADD < 2 mm", "ADD > 10 mm",
               "converged", "poses"], label_header="run", digits=3, caption=a.caption)
    for spec in a.run:
        label, path, flt = parse_run(spec)
        rows = select(path, flt)
        if not rows:
            raise SystemExit(f"{path}: no rows match {spec!r}")
        vals = summarise(rows)
        t.rows.append(Row(label, vals))
        print(f"{label}: " + " ".join(f"{v:.3f}" for v in vals))
    for p in write_table(t, Path(a.out), a.name):
        print(p)


if __name__ == "__main__":
    main()
