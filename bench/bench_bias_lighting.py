"""Does the scene lighting cause the refiner's rotation bias? Refine from the exact GT, cameras fixed
at the GT, on frames of one suite scene rendered by Blender in several lightings (``--variants``):
with the suite's lights (``suite``: a sun from above plus a weak ambient world), with an ambient
world only (``ambient``: no directional light, so the unlit templates match the image's shading far
better) or as pure emission (``emission``: the texture's colour, no light at all, so what is left is
the image formation and the cost itself). The rest is identical: geometry, textures, noise, camera,
objects, GT. ``emission_point`` / ``suite_point``: Cycles sampling the pixel centres only (pixel filter
0.01 px, many samples, no denoiser), the image formed as the fast renderer forms its templates.
``world_sun`` / ``world_two``: lights fixed in the world instead of to the camera (the suite's sun held
at frame 0's world direction; plus a second sun from the right), as a room lights a hand-held clip.
Controls, not evidence (the inverse crime on purpose): ``fast``, ``fast_clean``, ``fast_flat``, ``fast_area``
render the frames with the refiner's own fast renderer (shaded with noise, shaded without, the
texture's colour only without noise, the same integrated over each pixel: ``bench_inverse_crime.py``);
what the refinement leaves there belongs to the cost, not to Blender.

Prints per object the rotation (deg; its mean axis in the model frame) and translation (mm) the
refinement leaves from the GT, per lighting and per term set (``--terms``: all terms, points only,
edges only), with ``--options`` (RefineOptions overrides, JSON) for every run. A bias that shrinks
with the ambient render is caused by the template-vs-image shading difference.

    python bench/bench_bias_lighting.py --dataset ../shared/data/ycbv --out /tmp/bias_light --scene 1
    python bench/bench_bias_lighting.py --dataset ../shared/data/ycbv --out /tmp/bl66 --suite ycbv21-long3 \
        --scene 66 --variants suite,emission --terms "points only,edges only"
"""
from __future__ import annotations

import argparse
import json
import shutil
import warnings
from pathlib import Path

import numpy as np

TERM_SETS = {"all terms": {}, "points only": {"use_edge": False},
             "edges only": {"use_point": False, "use_temporal": False}}


# lighting variants: (name, render_blender keyword arguments)
VARIANTS = {"suite": ("sun + ambient (suite)", {}),
            "ambient": ("ambient only", {"lights": [], "world_strength": 1.0}),
            "emission": ("unlit (emission: the texture's colour only)", {"material": "emission"}),
            # the pixel centres only (Cycles' pixel filter 0.01 px), no denoiser: the image formed as the
            # fast renderer forms its templates (session 41: then the two agree on geometry and texture)
            "emission_point": ("unlit, pixel centres, 64 spp, no denoiser",
                               {"material": "emission", "samples": 64, "denoise": False, "filter_width": 0.01}),
            # the suite's pixel filter (1 px) without its denoiser: what the denoiser does to the edges
            "emission_nodenoise": ("unlit, the suite's 1 px pixel filter, 64 spp, no denoiser",
                                   {"material": "emission", "samples": 64, "denoise": False}),
            "suite_nodenoise": ("sun + ambient, the suite's 1 px pixel filter, 128 spp, no denoiser",
                                {"samples": 128, "denoise": False}),
            "suite_point": ("sun + ambient, pixel centres, 128 spp, no denoiser",
                            {"samples": 128, "denoise": False, "filter_width": 0.01}),
            # lights that stay put in the world while the camera moves, as a room's lights do (the suite's
            # sun is fixed to the camera): frame 0 of the clip is lit exactly as the suite lights it, then
            # the sun keeps that world direction; ``world_two`` adds a second, weaker sun from the camera's
            # right (at frame 0), so two shadows move across the objects between views
            "world_sun": ("the suite's sun and ambient world, the sun fixed in the world (frame 0's direction)",
                          {"world_lights": [{"type": "SUN", "direction_cam": [0.25, 1.0, 0.6], "strength": 3.5,
                                             "angle_deg": 25.0}]}),
            "world_two": ("two suns fixed in the world (the suite's and one from the right) and the ambient world",
                          {"world_lights": [{"type": "SUN", "direction_cam": [0.25, 1.0, 0.6], "strength": 3.5,
                                             "angle_deg": 25.0},
                                            {"type": "SUN", "direction_cam": [-0.9, 0.5, 0.2], "strength": 2.0,
                                             "angle_deg": 10.0}]}),
            # a control, not evidence: the refiner's own fast renderer (the inverse crime on purpose). A
            # rest left here belongs to the cost itself, not to how Blender forms the image
            # (``fast``: a bench_inverse_crime.render_control mode; ``noise_sigma``: sensor noise on top)
            "fast": ("the refiner's own fast renderer (control)", {"fast": "shaded", "noise_sigma": 1.5}),
            "fast_clean": ("the refiner's own fast renderer, no noise (control)", {"fast": "shaded"}),
            "fast_flat": ("the refiner's own fast renderer, no noise, no shading: the texture's colour (control)",
                          {"fast": "point"}),
            "fast_area": ("the refiner's own fast renderer, the texture's colour integrated over each pixel (4 x 4, "
                          "linear light; control)", {"fast": "area"})}


def render_variant(spec, models: dict, root: Path, frames: list[int], light: dict) -> Path:
    """Blender-render ``frames`` of suite scene ``spec`` with ``light`` (a :data:`VARIANTS` entry's
    keyword arguments) into a BOP dataset under ``root``."""
    from ycbvss.gt_info import compute_gt_info
    from ycbvss.pipeline.blender_scene import render_blender
    from ycbvss.io.bop import BopSceneWriter
    from ycbvss.procedural.ycbv_scene import make_ycbv_scene
    from ycbvss.render import Renderer

    if (root / "test" / f"{spec.scene_id:06d}" / "scene_gt.json").is_file():
        return root
    sc = make_ycbv_scene(models, list(spec.obj_ids), seed=spec.seed, n_frames=spec.n_frames,
                         arc_deg=spec.arc_deg, width=640, height=480, scene_id=spec.scene_id)
    sc.frames = [f for f in sc.frames if f.im_id in set(frames)]
    gl = Renderer()
    writer = BopSceneWriter(root / "test", spec.scene_id)
    by_id = {f.im_id: f for f in sc.frames}
    if light.get("fast"):
        from bench_inverse_crime import render_control
        from ycbvss.procedural.render import render_frame_fast
        rng = np.random.default_rng(spec.seed + 7)
        sigma = light.get("noise_sigma", 0.0)
        frames_out = ((f.im_id, render_control(sc, f, gl, light["fast"], 4) if sigma == 0.0 else
                       render_frame_fast(sc, f, gl, noise_sigma=sigma, rng=rng)[0], render_frame_fast(sc, f, gl)[1])
                      for f in sc.frames)
    elif light.get("world_lights"):
        frames_out = _render_world_lit(sc, root, light, gl)
    else:
        frames_out = render_blender(sc, root / "models", root / "work", **{"samples": 12, **light})
    for im_id, rgb, depth in frames_out:
        masks, masks_visib, info = compute_gt_info(gl, by_id[im_id], models, depth_mm_real=depth)
        writer.write_frame(by_id[im_id], rgb=rgb, depth_mm=depth, masks=masks, masks_visib=masks_visib,
                           gt_info=info)
    writer.close()
    return root


def world_fixed_lights(lights_cam0: list, T_w2c_0: np.ndarray, T_w2c: np.ndarray) -> list:
    """Blender light specs for a camera at ``T_w2c`` of lights whose travel directions
    (``direction_cam``) are given in the camera at ``T_w2c_0`` and stay fixed in the world."""
    R = np.asarray(T_w2c, np.float64)[:3, :3] @ np.asarray(T_w2c_0, np.float64)[:3, :3].T
    return [{**spec, "direction_cam": (R @ np.asarray(spec["direction_cam"], np.float64)).tolist()}
            for spec in lights_cam0]


def _render_world_lit(sc, root: Path, light: dict, renderer):
    """(im_id, rgb, depth) of every frame of ``sc`` rendered as ``render_blender`` renders them (the
    same per-frame Cycles seeds, compositing and sensor noise as the suite's frames), but lit by
    ``light["world_lights"]`` fixed in the world: the suite's generator lights a whole job once, so
    its job runner is swapped here, for this call only, for one Blender worker that is re-lit
    before each frame."""
    from ycbvss.pipeline import blender_scene
    from ycbvss.synth import blender as sb

    T0 = sc.frames[0].T_w2c
    lights = {f"{f.im_id:06d}": world_fixed_lights(light["world_lights"], T0, f.T_w2c) for f in sc.frames}

    def render_job(job: dict, workers: int = 1, on_done=None) -> list:
        settings = {k: job[k] for k in sb._SETTING_KEYS if k in job}
        settings = {"width": 640, "height": 480, **settings, "threads": sb.default_workers()}
        out = []
        with sb.BlenderWorker() as w:
            for fr in job["frames"]:
                w.configure({**settings, "lights": lights[fr["id"]]})
                r = w.request({"cmd": "render", "frame": fr, "meshes": job["meshes"],
                               "seed": sb.frame_seed(int(job.get("seed", 0)), fr["id"])})
                r.pop("warnings", None)
                out.append(r)
                if on_done is not None:
                    on_done(r)
        return out

    rest = {k: v for k, v in light.items() if k != "world_lights"}
    original = blender_scene.render_job
    blender_scene.render_job = render_job
    try:
        yield from blender_scene.render_blender(sc, root / "models", root / "work", renderer=renderer,
                                                **{"samples": 12, **rest})
    finally:
        blender_scene.render_job = original


def bias_from_gt(root: Path, spec, models: dict, opts: dict) -> dict:
    """{obj_id: (R deg, mean rotation vector deg in the model frame (3,), mean translation mm (3,))}."""
    from scipy.spatial.transform import Rotation

    from ycbvss.io.bop import load_bop_scene
    from ycbvss.refine.bundle import RefineOptions, refine_scene

    scene = load_bop_scene(root / "test", spec.scene_id, models)
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in scene.frames for i in f.instances}
    res = refine_scene(scene, models, dict(gt), RefineOptions(**{"seed": 0, "fix_cameras": True, **opts}))
    out = {}
    for o in spec.obj_ids:
        ks = [k for k in gt if k[1] == o and k in res.poses]
        rv = np.array([Rotation.from_matrix(gt[k][:3, :3].T @ res.poses[k][:3, :3]).as_rotvec() for k in ks])
        dt = np.mean([res.poses[k][:3, 3] - gt[k][:3, 3] for k in ks], axis=0)
        out[o] = (float(np.degrees(np.linalg.norm(rv, axis=1)).mean()), np.degrees(rv.mean(axis=0)), dt)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--dataset", required=True, help="YCB-Video root (models/) or BOP root (models/)")
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--suite", default="ycbv21", help="a suite of ycbvss.pipeline.suite.SUITES")
    ap.add_argument("--scene", type=int, default=1, help="a scene of the suite with >= 176 frames (ycbv21: 1-3)")
    ap.add_argument("--frames", default="0,25,50,75,100,125,150,175")
    ap.add_argument("--variants", default="suite,ambient", help=f"lightings to render, of {','.join(VARIANTS)}")
    ap.add_argument("--terms", default=",".join(TERM_SETS), help=f"term sets, of {','.join(TERM_SETS)}")
    ap.add_argument("--options", default="{}", help="RefineOptions overrides for every run, a JSON object")
    a = ap.parse_args()
    warnings.simplefilter("ignore")
    from ycbvss.pipeline.suite import SUITES, suite_models

    spec = next(s for s in SUITES[a.suite] if s.scene_id == a.scene)
    frames = [int(x) for x in a.frames.split(",")]
    models = suite_models(a.dataset, a.out / "models_src", spec.obj_ids)
    results = {}
    for v in a.variants.split(","):
        name, light = VARIANTS[v]
        root = a.out / {"suite": "suite_lights"}.get(v, v)
        # every run: another --scene in the same --out brings models the first copy did not hold
        shutil.copytree(a.out / "models_src" / "models", root / "models", dirs_exist_ok=True)
        render_variant(spec, models, root, frames, light)
        for terms in a.terms.split(","):
            results[(name, terms)] = bias_from_gt(root, spec, models, {**json.loads(a.options), **TERM_SETS[terms]})
    for (name, terms), per in results.items():
        print(f"== {name}, {terms} (scene {spec.scene_id}, {len(frames)} frames, cameras fixed at GT; options {a.options})")
        for o, (r, axis, dt) in per.items():
            print(f"  obj {o:2d}: R {r:.3f} deg (axis {np.round(axis, 3)})  t {np.round(dt, 2)} mm")


if __name__ == "__main__":
    main()
