"""Robustness of the refiner over many initialisation seeds, from validation-suite rows.

    python bench/suite_robustness.py --rows OUT/rows.csv [more rows.csv ...] --out DIR

Reads the per-pose rows that ``ycbvss validate --suite`` writes (``rows.csv``; with several files a
later file's run replaces an earlier one with the same clip/init/seed/variant) and writes, per clip
of the paper-init, all-terms runs: the number of seeds, poses, poses with ADD > 10 mm, how many of
those were reported ``converged`` (silent failures; the issue's bound is 0), the status counts and
the share (%) refined to ADD < 2 mm. Tables: ``robustness.md``, ``.csv`` and ``.tex`` in DIR.
"""
from __future__ import annotations

import argparse
import sys
from collections import Counter, defaultdict
from pathlib import Path

from ycbvss.eval.tables import Row, Table, to_markdown, write_table
from ycbvss.pipeline.suite_run import read_rows

COLUMNS = ["seeds", "poses", "ADD>10mm", "ADD>10mm converged (silent)", "converged", "uncertain", "failed",
           "ADD<2mm (%)"]


def robustness_table(rows: list[dict]) -> Table:
    """One row per clip (and a total) of paper-init, all-terms poses; columns :data:`COLUMNS`."""
    by: dict[str, list[dict]] = defaultdict(list)
    for r in rows:
        if r["init"] == "paper" and r["variant"] == "using all":
            by[r["clip"]].append(r)
    order = {"short": 0, "medium": 1, "long": 2}
    t = Table(columns=COLUMNS, label_header="clip", digits=0,
              caption="Robustness over initialisation seeds (paper's initial error, all terms): poses with "
                      "ADD > 10 mm and how many of them were reported `converged`.")
    total = [0] * 7
    for clip in sorted(by, key=lambda c: (order.get(c.split("-")[0], 9), int(c.split("-")[-1]))):
        rs = by[clip]
        st = Counter(r["status"] for r in rs)
        big = [r for r in rs if float(r["add_mm"]) > 10.0]
        vals = [len({int(r["seed"]) for r in rs}), len(rs), len(big), sum(r["status"] == "converged" for r in big),
                st["converged"], st["uncertain"], st["failed"]]
        total = [x + y for x, y in zip(total, vals)]
        t.rows.append(Row(clip, [*vals, 100.0 * sum(float(r["add_mm"]) < 2.0 for r in rs) / len(rs)]))
    t.rows.append(Row("all", [None, *total[1:], None], rule_before=True))
    return t


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rows", nargs="+", required=True, help="rows.csv files of suite runs")
    ap.add_argument("--out", required=True, help="output folder")
    a = ap.parse_args(argv)
    runs: dict[tuple, list[dict]] = {}
    for p in a.rows:
        per_file: dict[tuple, list[dict]] = defaultdict(list)
        for r in read_rows(Path(p)):
            per_file[(r["clip"], r["init"], r["seed"], r["variant"])].append(r)
        runs.update(per_file)
    t = robustness_table([r for rs in runs.values() for r in rs])
    write_table(t, Path(a.out), "robustness")
    print(to_markdown(t))
    return 0


if __name__ == "__main__":
    sys.exit(main())
