"""How visible each object of the validation suite is, per scene: does it really appear in three?

    python bench/suite_visibility.py --suite-root /tmp/suite/full --out bench/results/ycbv21

Reads each built scene's ``scene_gt.json`` / ``scene_gt_info.json`` (BOP) under
``--suite-root/test`` and writes, per object and scene, the largest visible fraction and visible
pixel count over the scene's rendered frames, and per object the number of scenes where it is at
least ``--min-visib`` visible in some frame (the issue: every object in at least three scenes).
Tables: ``visibility.md``, ``.csv`` and ``.tex`` in ``--out``.
"""
from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

from ycbvss.eval.tables import Row, Table, to_markdown, write_table
from ycbvss.manifest import object_names


def scene_visibility(scene_dir: Path) -> dict[int, tuple[float, int]]:
    """obj_id -> (largest visib_fract, largest px_count_visib) over the scene's frames."""
    gt = json.loads((scene_dir / "scene_gt.json").read_text())
    info = json.loads((scene_dir / "scene_gt_info.json").read_text())
    best: dict[int, tuple[float, int]] = {}
    for im, insts in gt.items():
        for a, b in zip(insts, info[im]):
            o = int(a["obj_id"])
            f, px = best.get(o, (0.0, 0))
            best[o] = (max(f, float(b["visib_fract"])), max(px, int(b["px_count_visib"])))
    return best


def visibility_table(root: Path, min_visib: float) -> Table:
    scenes = sorted(p for p in (root / "test").iterdir() if (p / "scene_gt_info.json").is_file())
    per_obj: dict[int, dict[int, tuple[float, int]]] = defaultdict(dict)
    for s in scenes:
        for o, v in scene_visibility(s).items():
            per_obj[o][int(s.name)] = v
    names = object_names()
    t = Table(columns=["scenes", f"scenes >= {min_visib:.0%} visible", "least visible scene",
                       "its max visible fraction", "its max visible px"],
              label_header="object", digits=2,
              caption=f"Per object: the suite scenes it is placed in, those where some frame shows at least "
                      f"{min_visib:.0%} of it, and its least visible scene (largest visible fraction and pixel "
                      f"count over that scene's frames).")
    for o in sorted(per_obj):
        vis = per_obj[o]
        worst = min(vis, key=lambda s: vis[s][0])
        t.rows.append(Row(names.get(o, str(o)), [float(len(vis)), float(sum(v[0] >= min_visib for v in vis.values())),
                                                 float(worst), vis[worst][0], float(vis[worst][1])]))
    return t


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--suite-root", required=True, help="suite dataset root (with test/<scene>/)")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--min-visib", type=float, default=0.3, help="visible fraction that counts as appearing")
    a = ap.parse_args(argv)
    t = visibility_table(Path(a.suite_root), a.min_visib)
    write_table(t, Path(a.out), "visibility")
    print(to_markdown(t))
    return 0


if __name__ == "__main__":
    sys.exit(main())
