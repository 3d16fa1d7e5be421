"""Render the long multi-object sequence the tracking benchmark's baseline is reported on.

A YCB-V table-top scene of six objects (003 cracker box, 006 mustard, 024 bowl, 025 mug,
036 wood block, 061 foam brick) on a 400-frame, 90-degree hand-held camera path, rendered by
Blender Cycles at 320x240 (8 samples) into a BOP dataset (``OUT/test/000041``) with the suite's
machinery (``ycbvss.pipeline.suite.build_scene``; deterministic, cached). The images come from
Blender, never from the fast renderer the baseline tracker draws its templates with. About 15 min
on 2 busy cores.

    python bench/make_tracking_sequence.py --ycbv ../shared/data/ycbv --out /tmp/ycbv400
    ycbvss benchmark make --dataset /tmp/ycbv400 --protocol ycbv --out cfg.json --lengths 10,20,40,80 --steps 2,4
    ycbvss benchmark run --config cfg.json --tracker baseline --out res/baseline
    ycbvss benchmark score --config cfg.json --results res/baseline res/static --out score
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from ycbvss.pipeline.suite import SuiteScene, build_scene, suite_models


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ycbv", default=str(Path(__file__).resolve().parents[2] / "shared" / "data" / "ycbv"),
                    help="YCB-Video root (models) or a BOP root with the 21 YCB-V models")
    ap.add_argument("--out", required=True)
    ap.add_argument("--frames", type=int, default=400)
    ap.add_argument("--arc-deg", type=float, default=90.0)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--samples", type=int, default=8)
    args = ap.parse_args()
    t0 = time.perf_counter()
    root = Path(args.out)
    models = suite_models(args.ycbv, root)
    spec = SuiteScene(41, (2, 5, 13, 14, 16, 21), args.frames, args.arc_deg, 141)
    sdir = build_scene(spec, models, root, width=args.width, height=args.height, samples=args.samples)
    print(f"rendered {sdir} in {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
