"""Data-layer timings on ../shared/data: YCB-V/BOP readers, gt_info, `convert ycbv`.

    python bench/bench_io.py [--shared ../shared/data] [--texture-max-px N]

Prints one line per figure. Converts videos 0000 and 0001 (15 frames, all 21 models with full
4096 px textures unless --texture-max-px) into a temporary folder.
"""
from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("YCBVSS_NO_PROGRESS", "1")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--shared", default=str(Path(__file__).resolve().parents[2] / "shared" / "data"))
    ap.add_argument("--texture-max-px", type=int, default=None)
    a = ap.parse_args()
    ycbv = Path(a.shared) / "ycbv"

    from ycbvss.convert import convert_ycbv
    from ycbvss.gt_info import compute_gt_info
    from ycbvss.io.bop import load_dataset
    from ycbvss.io.ycbv import load_ycbv_dataset
    from ycbvss.render import Renderer

    t = time.perf_counter()
    ds = load_ycbv_dataset(ycbv)
    print(f"load_ycbv_dataset (21 models: vertices, diameters): {time.perf_counter() - t:.2f} s")
    t = time.perf_counter()
    n = sum(len(ds.load_scene(v).frames) for v in ds.scene_ids)
    print(f"YCB-V scene loading (meta.mat): {1000 * (time.perf_counter() - t) / n:.1f} ms/frame")

    with tempfile.TemporaryDirectory() as tmp:
        t, c = time.perf_counter(), time.process_time()
        r = convert_ycbv(ycbv, tmp, videos="0000,0001", texture_max_px=a.texture_max_px, show_progress=False)
        total = time.perf_counter() - t
        print(f"convert CPU time (all threads of this process): {time.process_time() - c:.1f} s; "
              f"load average now {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
        n_f = r["frames_written"]
        print(f"convert ycbv 0000,0001: total {total:.1f} s; 21 models {r['seconds_models']:.1f} s; "
              f"{n_f} frames {(total - r['seconds_models']):.1f} s "
              f"({1000 * (total - r['seconds_models']) / n_f:.0f} ms/frame incl. EGL context start)")
        size = sum(p.stat().st_size for p in Path(tmp).rglob("*") if p.is_file())
        print(f"output size: {size / 1e6:.0f} MB")
        t = time.perf_counter()
        r2 = convert_ycbv(ycbv, tmp, videos="0000,0001", show_progress=False)
        print(f"idempotent re-run: {time.perf_counter() - t:.1f} s ({r2['frames_skipped']} frames skipped)")

        t = time.perf_counter()
        bds = load_dataset(tmp, "train_real")
        frames = [f for s in bds.scene_ids for f in bds.load_scene(s).frames]
        print(f"BOP load_dataset + scenes: {1000 * (time.perf_counter() - t) / len(frames):.1f} ms/frame")
        rend = Renderer()
        compute_gt_info(rend, frames[-1], bds.models, frames[-1].load_depth_mm())     # warm up
        t = time.perf_counter()
        depths = [f.load_depth_mm() for f in frames]
        t_depth = time.perf_counter() - t
        t = time.perf_counter()
        for f, d in zip(frames, depths):
            compute_gt_info(rend, f, bds.models, d)
        print(f"compute_gt_info (3-4 objects, 640x480, llvmpipe): "
              f"{1000 * (time.perf_counter() - t) / len(frames):.1f} ms/frame; depth read "
              f"{1000 * t_depth / len(frames):.1f} ms/frame")


if __name__ == "__main__":
    main()
