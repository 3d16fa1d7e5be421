"""Pose-weighted merge of per-object suite tables (``objects_<kind>.csv`` written by
``bench/suite_runs.py report``) from runs whose rows are no longer at hand: each object's mean
error is the mean of the tables' means weighted by their pose counts, which equals the mean over
all their poses. Writes ``OUT.md``, ``OUT.csv`` and ``OUT.tex`` and prints the objects missing a target.

    python bench/merge_object_tables.py --kind long --out DIR/objects_long_merged \\
        --title "..." A/objects_long.csv B/objects_long.csv
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from ycbvss.eval.tables import ERROR_HEADERS as COLS, ERROR_LATEX, Row, Table, write_table
from ycbvss.pipeline.suite_report import TARGETS


def merge(paths: list[Path]) -> dict[str, tuple[np.ndarray, int, bool]]:
    """object -> (pose-weighted mean errors (5,), poses, textureless) over the tables ``paths``."""
    acc: dict[str, tuple[np.ndarray, float]] = {}
    marks: dict[str, bool] = {}
    for p in paths:
        with open(p, newline="") as fh:
            for r in csv.DictReader(fh):
                name = r["object"]
                if name.startswith(("all", "paper")):
                    continue
                n = float(r["poses"])
                marks[name] = r.get("textureless") in ("1", "True")
                s, m = acc.get(name, (np.zeros(len(COLS)), 0.0))
                acc[name] = (s + n * np.array([float(r[c]) for c in COLS]), m + n)
    return {o: (s / n, int(n), marks[o]) for o, (s, n) in acc.items() if n > 0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("tables", nargs="+", type=Path)
    ap.add_argument("--kind", choices=sorted(TARGETS), required=True)
    ap.add_argument("--out", type=Path, required=True, help="path without suffix: OUT.md, OUT.csv, OUT.tex")
    ap.add_argument("--title", default="")
    a = ap.parse_args()
    tgt = TARGETS[a.kind]
    m = merge(a.tables)
    mean = np.mean([v for v, _, _ in m.values()], axis=0)
    total = sum(n for _, n, _ in m.values())
    t = Table(columns=[*COLS, "poses"], label_header="object", latex_columns=[*ERROR_LATEX, "poses"],
              caption=a.title)
    for o in sorted(m):
        v, n, textureless = m[o]
        t.rows.append(Row(o, list(v) + [n], mark=textureless, bold=[x > g for x, g in zip(v, tgt)] + [False]))
    t.rows.append(Row("all (mean over objects)", list(mean) + [total], rule_before=True, bold=[False] * 6))
    write_table(t, a.out.parent, a.out.name)
    misses = {o: [f"{c.split()[0]} {x:.2f}" for c, x, g in zip(COLS, v, tgt) if x > g] for o, (v, _, _) in m.items()}
    print(f"{len(m)} objects, {total} poses; mean over objects " + " / ".join(f"{x:.3f}" for x in mean)
          + f"; {sum(not x for x in misses.values())} of {len(m)} meet every {a.kind} target")
    for o, x in sorted(misses.items()):
        if x:
            print(f"  {o}: {', '.join(x)}")


if __name__ == "__main__":
    main()
