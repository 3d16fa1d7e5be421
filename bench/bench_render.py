"""Benchmark of the headless renderer (ycbvss.render) on the YCB-V camera.

Six real textured YCB-V models (16384 faces each; decimated to ~16k if larger), 640x480, K of the YCB-Video
'uw' camera, placed in front of the camera with mutual occlusion.  Median time per frame (after warm-up)
over N frames for several output sets.  Run: ``python bench/bench_render.py [--frames 100]``.
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
MODELS = Path(os.environ.get("YCBVSS_SHARED_DATA", REPO.parent / "shared" / "data")) / "ycbv" / "models"
NAMES = ["002_master_chef_can", "003_cracker_box", "004_sugar_box", "006_mustard_bottle",
         "010_potted_meat_can", "025_mug"]
K_UW = np.array([[1066.778, 0.0, 312.9869], [0.0, 1067.487, 241.3109], [0.0, 0.0, 1.0]])
TARGET_FACES = 16384


def load_models():
    import trimesh

    meshes = {}
    for name in NAMES:
        m = trimesh.load(MODELS / name / "textured.obj", force="mesh", process=False)
        m.apply_scale(1000.0)  # metres -> mm
        if len(m.faces) > 1.1 * TARGET_FACES:  # (the YCB-V Google-16k meshes all have 16384 faces)
            m = decimate(m, TARGET_FACES)
        meshes[name] = m
    return meshes


def decimate(mesh, faces: int):
    """Quadric edge-collapse decimation with pymeshlab (geometry only: the result is rendered grey)."""
    import pymeshlab
    import trimesh

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(np.asarray(mesh.vertices, np.float64), np.asarray(mesh.faces, np.int32)))
    ms.meshing_decimation_quadric_edge_collapse(targetfacenum=int(faces), preservenormal=True)
    m = ms.current_mesh()
    return trimesh.Trimesh(m.vertex_matrix(), m.face_matrix(), process=False)


def scene_poses(rng: np.random.Generator) -> list[np.ndarray]:
    """Six poses on a 3x2 grid ~0.8-1 m away, close enough to overlap in the image."""
    from ycbvss.geometry.so3 import random_rotation

    poses = []
    for k in range(6):
        T = np.eye(4)
        T[:3, :3] = random_rotation(rng) if _takes_rng() else random_rotation()
        T[:3, 3] = [(-100 + 100 * (k % 3)) + rng.normal(0, 10), (-60 + 120 * (k // 3)) + rng.normal(0, 10),
                    800 + 60 * k]
        poses.append(T)
    return poses


def _takes_rng() -> bool:
    import inspect

    from ycbvss.geometry.so3 import random_rotation
    return len(inspect.signature(random_rotation).parameters) > 0


def time_outputs(r, items, outputs, frames: int, warmup: int = 5) -> tuple[float, float, float, float]:
    """(median wall ms, min wall ms, process CPU ms incl. llvmpipe threads, main-thread CPU ms) per frame."""
    for _ in range(warmup):
        r.render(K_UW, 640, 480, items, outputs=outputs)
    ts = []
    c0, m0 = time.process_time(), time.thread_time()
    for _ in range(frames):
        t0 = time.perf_counter()
        r.render(K_UW, 640, 480, items, outputs=outputs)
        ts.append(time.perf_counter() - t0)
    cpu = (time.process_time() - c0) / frames
    main = (time.thread_time() - m0) / frames
    return 1000.0 * float(np.median(ts)), 1000.0 * float(np.min(ts)), 1000.0 * cpu, 1000.0 * main


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=100)
    args = ap.parse_args()

    from ycbvss.render import Renderer, context_info

    t0 = time.perf_counter()
    meshes = load_models()
    t_load = time.perf_counter() - t0
    r = Renderer()
    t0 = time.perf_counter()
    for name, m in meshes.items():
        r.add_mesh(name, m)
    t_upload = time.perf_counter() - t0
    items = list(zip(NAMES, scene_poses(np.random.default_rng(0))))
    probe = r.render(K_UW, 640, 480, items, outputs=("instance", "mask_all"))
    visible = [int((probe.instance == k + 1).sum()) for k in range(6)]
    full = [int(m.sum()) for m in probe.masks_all]
    occl = [1 - v / f if f else 0 for v, f in zip(visible, full)]

    info = context_info()
    print(f"renderer: {info['GL_RENDERER']} | {info['GL_VERSION']} | LP_NUM_THREADS="
          f"{os.environ.get('LP_NUM_THREADS', 'default')} | cpus={os.cpu_count()}")
    print(f"models: {', '.join(NAMES)}; faces: {[len(m.faces) for m in meshes.values()]}")
    print(f"load {t_load:.1f} s, upload (incl. texture mipmaps) {t_upload:.2f} s; object pixels visible "
          f"{visible}, occluded fraction {[round(o, 2) for o in occl]}")
    print(f"load average before timing: {os.getloadavg()[0]:.2f} (wall times inflate when other processes run)")
    print()
    nthreads = int(os.environ.get("LP_NUM_THREADS", os.cpu_count() or 1))
    print(f"| outputs (640x480, 6 objects) | median ms/frame ({args.frames} frames) | min ms | CPU ms/frame "
          f"(all threads) | main-thread CPU ms | idle-machine estimate ms |")
    print("|---|---|---|---|---|---|")
    sets = [("depth", "instance"), ("depth",), ("instance",), ("depth", "instance", "normal"),
            ("depth", "instance", "color"), ("depth", "instance", "normal", "color"), ("mask_all",)]
    for outs in sets:
        med, mn, cpu, main = time_outputs(r, items, outs, args.frames)
        # main thread (python, vertex stage, binning, readback) is serial; llvmpipe rasterises in nthreads
        est = main + (cpu - main) / max(nthreads, 1)
        print(f"| {'+'.join(outs)} | {med:.2f} | {mn:.2f} | {cpu:.2f} | {main:.2f} | {est:.2f} |")
    print(f"load average after timing: {os.getloadavg()[0]:.2f}")
    print("idle-machine estimate = main-thread CPU + (other threads' CPU) / LP threads: wall time on 2 free cores")


if __name__ == "__main__":
    main()
