"""The demo's Table 5 (ablation on its keyframes) over several seeds: is a term's contribution
larger than the seed-to-seed spread?

    python bench/demo_seeds.py --seeds 0,1,2 --work /tmp/demo_seeds --out bench/results/demo_seeds

Each seed runs ``ycbvss demo --seed N --out WORK/seedN`` (a seed changes the render noise, the
initial poses and the refiner's sampling) unless ``WORK/seedN/summary.json`` exists. Writes one
table per seed and the mean over seeds (Markdown, CSV, LaTeX): tx, ty, tz mm, R deg, PRJ px and
ADD mm of every variant on the keyframes, the variants run as ``ycbvss demo`` runs them.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

from ycbvss.eval.tables import Row, Table, write_table

COLS = ("tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px", "add_mm")
HEADERS = ("tx (mm)", "ty (mm)", "tz (mm)", "R (deg)", "PRJ (px)", "ADD (mm)")
VARIANTS = ("w/o f_edge", "w/o f_point", "w/o f_t", "using all")


def variant_means(summary: dict) -> dict[str, list[float]]:
    """{variant: [tx, ty, tz, R, PRJ, ADD]} of a demo's ``summary.json`` (keyframe means)."""
    kf = summary["variants_keyframes"]
    return {v: [float(kf[v][c]) for c in COLS] for v in VARIANTS if v in kf}


def table_of(rows: dict[str, list[float]], caption: str) -> Table:
    t = Table(list(HEADERS), label_header="configuration", caption=caption, digits=4)
    t.rows = [Row(v, vals) for v, vals in rows.items()]
    for c in range(len(HEADERS)):
        best = min(r.values[c] for r in t.rows)
        for r in t.rows:
            r.bold = r.bold or [False] * len(HEADERS)
            r.bold[c] = r.values[c] == best
    return t


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args(argv)
    seeds = [int(s) for s in a.seeds.split(",")]
    per_seed = {}
    for s in seeds:
        d = a.work / f"seed{s}"
        if not (d / "summary.json").is_file():
            subprocess.run([sys.executable, "-c", "import sys; from ycbvss.cli import main; sys.exit(main())",
                            "demo", "--seed", str(s), "--out", str(d)], check=True)
        per_seed[s] = variant_means(json.loads((d / "summary.json").read_text()))
        write_table(table_of(per_seed[s], f"ycbvss demo --seed {s}: ablation on the keyframes (bold: best)"),
                    a.out, f"demo_ablation_seed{s}")
    mean = {v: list(np.mean([per_seed[s][v] for s in seeds], axis=0)) for v in VARIANTS}
    t = table_of(mean, f"ycbvss demo, mean over seeds {a.seeds}: ablation on the keyframes (bold: best)")
    write_table(t, a.out, "demo_ablation_mean")
    from ycbvss.eval.tables import to_markdown
    print(to_markdown(t))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
