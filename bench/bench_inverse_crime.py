"""Inverse-crime controls of the validation suite: a suite scene's frames re-rendered by the refiner's
own fast renderer, so that refining them from the exact GT shows what the cost leaves by itself.

These images are controls, never evidence of accuracy: the refiner's templates come from the same
renderer. What a refinement from the exact GT leaves on them belongs to the cost (its sampling, its
models of the image formation), not to how Blender lights and films the scene.

Writes a copy of the suite root (``--out``) whose scenes hold the same GT, depth and masks as the
source (symbolic links) and new RGB images, one mode per copy:

- ``point``: the texture's colour (no shading, no noise), sampled at the pixel centres, exactly as
  the refiner's point-sampled templates are formed;
- ``area``: the same, integrated over each pixel at ``--supersample`` x ``--supersample`` sub-pixels in
  linear light (what a camera and Cycles' pixel filter do, and what the refiner's area templates and
  its contour appearance model assume);
- ``shaded``: the fast renderer's own ambient + diffuse shading (applied to sRGB values), pixel centres.

Then refine the copy from the exact GT with ``suite_runs.py``:

    python bench/bench_inverse_crime.py --dataset ../shared/data/ycbv --suite-root /tmp/suite/full \
        --scenes 1 --mode area --out /tmp/ic_area
    python bench/suite_runs.py run --dataset ../shared/data/ycbv --suite ycbv21 --suite-root /tmp/ic_area \
        --scenes 1 --kinds long --inits gt --seeds 0 --work /tmp/ic_area_run
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import warnings
from pathlib import Path

import numpy as np


def subpixel_camera(cam, s: int):
    """The camera whose s x s sub-pixels tile each pixel of ``cam`` (pixel centres at integers: the
    sub-pixel (U, V) of pixel (u, v) sits at U = s u + (s - 1) / 2 + k, k = -(s-1)/2 .. (s-1)/2)."""
    from ycbvss.camera import Camera

    K = np.array(cam.K, np.float64)
    K2 = K.copy()
    K2[0, 0], K2[1, 1] = s * K[0, 0], s * K[1, 1]
    K2[0, 2], K2[1, 2] = s * K[0, 2] + (s - 1) / 2.0, s * K[1, 2] + (s - 1) / 2.0
    return Camera(K2, cam.width * s, cam.height * s)


def render_control(sc, frame, renderer, mode: str, supersample: int) -> np.ndarray:
    """One frame's control image (H, W, 3) uint8 sRGB in ``mode`` (see the module docstring)."""
    from ycbvss.pipeline.blender_scene import linear_to_srgb_u8, srgb_u8_to_linear
    from ycbvss.procedural.render import render_frame_fast

    ambient, diffuse = (0.35, 0.75) if mode == "shaded" else (1.0, 0.0)
    if mode != "area":
        return render_frame_fast(sc, frame, renderer, ambient=ambient, diffuse=diffuse, noise_sigma=0.0)[0]
    s = int(supersample)
    big = render_frame_fast(sc, dataclasses.replace(frame, camera=subpixel_camera(frame.camera, s)), renderer,
                            ambient=ambient, diffuse=diffuse, noise_sigma=0.0)[0]
    h, w = frame.camera.height, frame.camera.width
    return linear_to_srgb_u8(srgb_u8_to_linear(big).reshape(h, s, w, s, 3).mean(axis=(1, 3)))


def main() -> None:
    import cv2
    from tqdm import tqdm

    from ycbvss.pipeline.suite import SUITES, suite_models
    from ycbvss.procedural.ycbv_scene import make_ycbv_scene
    from ycbvss.render import Renderer

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", required=True, help="YCB-Video root (models/) or BOP root with the 21 models")
    ap.add_argument("--suite-root", required=True, type=Path, help="the rendered suite (its GT, depth and masks)")
    ap.add_argument("--suite", default="ycbv21")
    ap.add_argument("--scenes", default="1")
    ap.add_argument("--mode", choices=("point", "area", "shaded"), default="area")
    ap.add_argument("--supersample", type=int, default=4, help="sub-pixels per axis of --mode area")
    ap.add_argument("--srgb-textures", action="store_true",
                    help="filter the textures in linear light (ycbvss.render.Renderer srgb_textures; session 88's "
                         "controls did not)")
    ap.add_argument("--out", required=True, type=Path)
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    (a.out / "test").mkdir(parents=True, exist_ok=True)
    if not (a.out / "models").exists():
        os.symlink((a.suite_root / "models").resolve(), a.out / "models")
    gl = Renderer(srgb_textures=a.srgb_textures)
    for sid in [int(x) for x in a.scenes.split(",")]:
        spec = next(s for s in SUITES[a.suite] if s.scene_id == sid)
        src, dst = a.suite_root / "test" / f"{sid:06d}", a.out / "test" / f"{sid:06d}"
        dst.mkdir(exist_ok=True)
        for p in src.iterdir():
            if p.name != "rgb" and not (dst / p.name).exists():
                os.symlink(p.resolve(), dst / p.name)
        (dst / "rgb").mkdir(exist_ok=True)
        models = suite_models(a.dataset, a.out.parent / f"{a.out.name}_models_src", spec.obj_ids)
        sc = make_ycbv_scene(models, list(spec.obj_ids), seed=spec.seed, n_frames=spec.n_frames, arc_deg=spec.arc_deg,
                             width=640, height=480, scene_id=sid)
        gt = json.loads((src / "scene_gt.json").read_text())
        worst = 0.0
        for f in tqdm(sc.frames, desc=f"scene {sid} ({a.mode})", unit="frame"):
            ref = {e["obj_id"]: np.array(e["cam_t_m2c"], float) for e in gt[str(f.im_id)]}
            worst = max([worst] + [float(np.abs(i.T_m2c[:3, 3] - ref[i.obj_id]).max()) for i in f.instances])
            rgb = render_control(sc, f, gl, a.mode, a.supersample)
            ext = next(src.glob(f"rgb/{f.im_id:06d}.*")).suffix
            tmp = dst / "rgb" / f".{f.im_id:06d}.tmp{ext}"
            cv2.imwrite(str(tmp), np.ascontiguousarray(rgb[..., ::-1]))
            os.replace(tmp, dst / "rgb" / f"{f.im_id:06d}{ext}")
        if worst > 1e-6:
            raise SystemExit(f"scene {sid}: the regenerated scene's GT differs from {src / 'scene_gt.json'} by "
                             f"{worst:.3g} mm")
        print(f"scene {sid}: {len(sc.frames)} frames ({a.mode}); GT identical to the suite's")


if __name__ == "__main__":
    main()
