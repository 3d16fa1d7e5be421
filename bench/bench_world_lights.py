"""The suite's clips lit by lights fixed in the world, refined as the suite refines its own.

Every ``ycbv21`` frame is lit by a sun fixed to the camera, so on a 60-degree long clip the light
turns with the camera; a room's lights stay put while a hand-held camera moves, and their shadows
move across the objects from view to view. This bench renders whole suite scenes with
``bench_bias_lighting.py``'s world-fixed variants (``world_sun``: the suite's sun kept at frame 0's
world direction; ``world_two``: plus a second sun from the right) with the suite's Blender settings
otherwise (Cycles, 12 spp, denoiser, 1 px pixel filter, sensor noise), then refines their clips
(``--kinds``, ``--inits``, ``--seeds``) with the default options through the suite's own run code
(:func:`ycbvss.pipeline.suite_run.execute`) and writes the suite's report (per-object, held-out,
bias, status and coverage tables). Scene 3 is held out of every tuning run, as in the suite.

    python bench/bench_world_lights.py --dataset ../shared/data/ycbv --out /tmp/world --scenes 1,3 \\
        --variant world_two --kinds long --inits paper --seeds 0

Rendering takes about 6 s per frame on 2 cores (one Blender job per frame, since the generator lights
a job once); the renders are kept under ``--out`` and reused.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", required=True, help="YCB-Video root (or BOP root) with the 21 models")
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--suite", default="ycbv21")
    ap.add_argument("--scenes", default="1,3")
    ap.add_argument("--variant", default="world_two", choices=("world_sun", "world_two"))
    ap.add_argument("--kinds", default="long")
    ap.add_argument("--inits", default="paper")
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--options", default=None, help="RefineOptions overrides: a JSON object, @FILE or FILE.json")
    ap.add_argument("--work", type=Path, help="rows, done markers and report (default OUT/runs_VARIANT; one "
                                              "folder per set of options)")
    a = ap.parse_args(argv)

    import shutil
    import warnings

    from bench_bias_lighting import VARIANTS, render_variant
    from ycbvss.pipeline.options import read_options_arg
    from ycbvss.pipeline.suite import SUITES, clips_of, rendered_frames, suite_models
    from ycbvss.pipeline.suite_report import visibility, write_report
    from ycbvss.pipeline.suite_run import Run, execute, read_rows

    warnings.simplefilter("ignore")
    opts_kw = read_options_arg(a.options)
    by_id = {s.scene_id: s for s in SUITES[a.suite]}
    specs = [by_id[int(x)] for x in a.scenes.split(",")]
    root = a.out / a.variant
    models = suite_models(a.dataset, a.out / "models_src", sorted({o for s in specs for o in s.obj_ids}))
    # every run: scenes added to an existing --out bring models the first copy did not hold
    shutil.copytree(a.out / "models_src" / "models", root / "models", dirs_exist_ok=True)
    _, light = VARIANTS[a.variant]
    for spec in specs:
        render_variant(spec, models, root, rendered_frames(spec), light)
    runs = [Run(c, i, int(s)) for sp in specs for c in clips_of(sp, a.kinds.split(","))
            for i in a.inits.split(",") for s in a.seeds.split(",")]
    print(f"{len(runs)} runs", flush=True)
    work = a.work or a.out / f"runs_{a.variant}"
    rows_path = execute(runs, root, models, work, opts_kw)
    vis = visibility(root, [s.scene_id for s in specs])
    for name, p in write_report(read_rows(rows_path), models, work / "report", vis).items():
        print(f"{name}: {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
