"""Pose-weighted merge of per-object suite tables (``objects_<kind>.csv`` written by
``bench/suite_runs.py report``) from runs whose rows are no longer at hand: each object's mean
error is the mean of the tables' means weighted by their pose counts, which equals the mean over
all their poses. Writes ``OUT.md`` and ``OUT.csv`` and prints the objects missing a target.

    python bench/merge_object_tables.py --kind long --out DIR/objects_long_merged \\
        --title "..." A/objects_long.csv B/objects_long.csv
"""
from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

COLS = ("tx (mm)", "ty (mm)", "tz (mm)", "R (deg)", "PRJ (px)")
# per-object targets of the suite (tx, ty, tz mm, R deg, PRJ px)
TARGETS = {"short": (0.3, 0.3, 1.5, 0.3, 0.5), "medium": (0.25, 0.25, 0.8, 0.2, 0.4),
           "long": (0.25, 0.25, 0.8, 0.2, 0.4)}


def merge(paths: list[Path]) -> dict[str, tuple[np.ndarray, int]]:
    """object -> (pose-weighted mean errors (5,), poses) over the tables ``paths``."""
    acc: dict[str, tuple[np.ndarray, float]] = {}
    for p in paths:
        with open(p, newline="") as fh:
            for r in csv.DictReader(fh):
                name = r["object"]
                if name.startswith(("all", "paper")):
                    continue
                n = float(r["poses"])
                s, m = acc.get(name, (np.zeros(len(COLS)), 0.0))
                acc[name] = (s + n * np.array([float(r[c]) for c in COLS]), m + n)
    return {o: (s / n, int(n)) for o, (s, n) in acc.items() if n > 0}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("tables", nargs="+", type=Path)
    ap.add_argument("--kind", choices=sorted(TARGETS), required=True)
    ap.add_argument("--out", type=Path, required=True, help="path without suffix: OUT.md and OUT.csv")
    ap.add_argument("--title", default="")
    a = ap.parse_args()
    tgt = TARGETS[a.kind]
    m = merge(a.tables)
    mean = np.mean([v for v, _ in m.values()], axis=0)
    total = sum(n for _, n in m.values())
    a.out.parent.mkdir(parents=True, exist_ok=True)
    lines = [a.title, "", "| object | " + " | ".join(COLS) + " | poses |", "|:---|" + "---:|" * (len(COLS) + 1)]
    with open(a.out.with_suffix(".csv.tmp"), "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(("object",) + COLS + ("poses",))
        for o in sorted(m):
            v, n = m[o]
            w.writerow([o] + [f"{x:.6g}" for x in v] + [n])
            cells = [(f"**{x:.2f}**" if x > t else f"{x:.2f}") for x, t in zip(v, tgt)]
            lines.append(f"| {o.replace('*', chr(92) + '*')} | " + " | ".join(cells) + f" | {n} |")
        w.writerow(["all (mean over objects)"] + [f"{x:.6g}" for x in mean] + [total])
    lines.append("| all (mean over objects) | " + " | ".join(f"{x:.3f}" for x in mean) + f" | {total} |")
    a.out.with_suffix(".csv.tmp").replace(a.out.with_suffix(".csv"))
    tmp = a.out.with_suffix(".md.tmp")
    tmp.write_text("\n".join(lines) + "\n")
    tmp.replace(a.out.with_suffix(".md"))
    misses = {o: [f"{c.split()[0]} {x:.2f}" for c, x, t in zip(COLS, v, tgt) if x > t] for o, (v, _) in m.items()}
    print(f"{len(m)} objects, {total} poses; mean over objects " + " / ".join(f"{x:.3f}" for x in mean)
          + f"; {sum(not x for x in misses.values())} of {len(m)} meet every {a.kind} target")
    for o, x in sorted(misses.items()):
        if x:
            print(f"  {o}: {', '.join(x)}")


if __name__ == "__main__":
    main()
