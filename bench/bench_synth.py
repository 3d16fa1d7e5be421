"""YCBV-SS synthesis benchmark.

Timing (default): seconds per 640x480 frame with 6 objects (the 4 objects of YCB-V video 0001 plus the
gelatin box and mug of video 0000, at their annotated poses, on the real frames of video 0001), all outputs
written (rgb, depth, masks, mask_visib, done marker), on this machine's cores; breakdown into Blender
render, composite (colour fit, noise, depth merge) and GT/gt_info + files. The first frame (Blender
start, mesh build, kernel load) is reported separately.

Accuracy (--accuracy): runs `ycbvss synth` on videos 0000 and 0001 and prints per object the chosen
scale, coverage before/after, dE before/after the colour fit, mask_visib IoU vs the fast renderer and the
median |dz| of the rendered depth vs the GT pose.

    python bench/bench_synth.py [--samples 8] [--frames 5] [--workers 1] [--accuracy]
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
YCBV = Path(os.environ.get("YCBVSS_SHARED_DATA", REPO.parent / "shared" / "data")) / "ycbv"


def timing(args) -> None:
    from ycbvss.geometry.model_frame import bbox_center
    from ycbvss.io.ycbv import load_ycbv_dataset
    from ycbvss.synth.executors import LocalExecutor
    from ycbvss.synth.models import write_dilated_models
    from ycbvss.synth.run import frame_task
    ds = load_ycbv_dataset(YCBV, [0, 1])
    s0, s1 = ds.load_scene(0), ds.load_scene(1)
    extra = [i for i in s0.frames[0].instances if i.obj_id in (8, 14)]
    obj_ids = sorted({i.obj_id for i in s1.frames[0].instances} | {i.obj_id for i in extra})
    centres = {o: bbox_center(ds.models[o].vertices_mm) for o in obj_ids}
    tmp = Path(tempfile.mkdtemp(prefix="bench_synth_"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        write_dilated_models(tmp / "models", ds.models, centres, {o: 1.03 for o in obj_ids})
    frames = s1.frames[: args.frames]
    tasks = []
    for f in frames:
        f.instances = list(f.instances) + extra
        tasks.append(frame_task(f, "ycbv", centres, {}))
    n_obj = len(tasks[0]["objects"])
    config = {"seed": 0, "render": {"samples": args.samples, "denoise": args.denoise, "max_bounces": 1},
              "noise": {}, "colour_fit": True,
              "meshes": {f"obj_{o:06d}": {"path": str(tmp / "models" / f"obj_{o:06d}.ply")} for o in obj_ids}}
    ex = LocalExecutor(args.workers)
    try:
        # warm-up frame (Blender start, mesh build, Cycles kernel load) into its own folder
        t0 = time.perf_counter()
        ex.map({**config, "split_dir": str(tmp / "warm")}, tasks[:ex.n], lambda r: None)
        t_warm = time.perf_counter() - t0
        res = []
        t0 = time.perf_counter()
        ex.map({**config, "split_dir": str(tmp / "test")}, tasks, res.append)
        wall = time.perf_counter() - t0
    finally:
        ex.close()
    keys = ("render_s", "composite_s", "gt_s", "total_s", "render_cpu_s", "composite_cpu_s", "gt_cpu_s", "total_cpu_s")
    tm = {k: np.mean([r["timing"][k] for r in res]) for k in keys}
    cores = ex.n * ex.threads
    lower = tm["total_cpu_s"] / cores      # perfectly parallel use of the cores: lower bound on an idle machine
    print(f"YCBV-SS synthesis, {len(res)} frames 640x480 with {n_obj} objects, {args.samples} spp, "
          f"denoise={args.denoise}, {ex.n} worker(s) x {ex.threads} thread(s), {os.cpu_count()} cores, "
          f"load avg {os.getloadavg()[0]:.1f}")
    print(f"  start-up (first frame per worker, incl. Blender start + mesh build): {t_warm:.2f} s")
    print(f"  wall clock per frame (throughput):      {wall / len(res):.3f} s   ({len(res) / wall:.2f} frames/s)")
    print("  per-frame worker breakdown:                 wall s   CPU s (all threads)")
    print(f"    Blender render (Cycles + EXR passes):   {tm['render_s']:7.3f}  {tm['render_cpu_s']:7.3f}")
    print(f"    composite (colour fit, noise, depth):   {tm['composite_s']:7.3f}  {tm['composite_cpu_s']:7.3f}")
    print(f"    GT masks/gt_info + writing files:       {tm['gt_s']:7.3f}  {tm['gt_cpu_s']:7.3f}")
    print(f"    total incl. reading inputs:             {tm['total_s']:7.3f}  {tm['total_cpu_s']:7.3f}")
    print(f"  CPU time per frame / {cores} cores (idle-machine lower bound): {lower:.3f} s")
    if os.getloadavg()[0] > cores:
        print("  NOTE: the machine is loaded by other processes (load average > cores): wall times are inflated")
    print(f"  target <= 1.0 s per frame (wall, throughput): {'MET' if wall / len(res) <= 1.0 else 'NOT MET'}")


def accuracy(args) -> None:
    from ycbvss.io.bop import load_dataset
    from ycbvss.io.images import read_mask
    from ycbvss.render import Renderer
    from ycbvss.synth.run import SynthOptions, run_synth
    out = Path(tempfile.mkdtemp(prefix="bench_synth_acc_")) / "ycbvss"
    t0 = time.perf_counter()
    rep = run_synth(YCBV, "test", out, scenes=[0, 1], opts=SynthOptions(samples=args.samples, workers=args.workers))
    print(f"synth of 15 frames: {time.perf_counter() - t0:.1f} s -> {out}")
    ds = load_dataset(out, "test")
    r = Renderer()
    for oid, m in ds.models.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            r.add_mesh(oid, m.mesh)
    iou, dz = {}, {}
    for sc in ds.iter_scenes():
        for f in sc.frames:
            ren = r.render(f.camera.K, 640, 480, [(i.obj_id, i.T_m2c) for i in f.instances])
            d = f.load_depth_mm()
            for k, inst in enumerate(f.instances):
                mv = read_mask(Path(f.rgb_path).parent.parent / "mask_visib" / f"{f.im_id:06d}_{k:06d}.png")
                fast = ren.instance == k + 1
                iou.setdefault(inst.obj_id, []).append((mv & fast).sum() / max((mv | fast).sum(), 1))
                both = mv & fast
                dz.setdefault(inst.obj_id, []).append(np.median(np.abs(d[both] - ren.depth_mm[both])))
    print("| obj | name | scale | coverage before | coverage after | dE before | dE after | dE final | "
          "min IoU mask_visib | max median abs dz (mm) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for oid, o in rep["objects"].items():
        i = int(oid)
        print(f"| {i} | {o['name']} | {o['scale']:.3f} | {o['coverage_before']:.4f} | {o['coverage_after']:.4f} | "
              f"{o['dE_before']:.2f} | {o['dE_after']:.2f} | {o['dE_final']:.2f} | {min(iou[i]):.4f} | "
              f"{max(dz[i]):.3f} |")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--samples", type=int, default=4)
    p.add_argument("--denoise", action="store_true")
    p.add_argument("--frames", type=int, default=5)
    p.add_argument("--workers", type=int, default=None, help="default: cores/2 workers x 2 threads")
    p.add_argument("--accuracy", action="store_true")
    args = p.parse_args()
    os.environ.setdefault("YCBVSS_NO_PROGRESS", "1")
    if not YCBV.is_dir():
        print(f"sample data not found: {YCBV}", file=sys.stderr)
        return 2
    (accuracy if args.accuracy else timing)(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
