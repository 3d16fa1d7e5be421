"""Photo-realistic rendering of a procedural scene with Blender (Cycles, CPU) through
:func:`ycbvss.synth.blender.render_job` -- the demo's default renderer.

The models are written as BOP PLY files first (:func:`write_models`). Blender renders the
objects only (transparent film, cropped to the objects' bounding box, which keeps Cycles fast
on small machines); the premultiplied linear RGBA is composited over the table rendered by the
fast OpenGL renderer (textured, Lambertian; no cast shadows) and encoded to sRGB uint8. The depth
image is the exact z-buffer of objects + table. ``with_table=True`` renders the table in
Blender as well (slow: the whole frame is path traced).
"""
from __future__ import annotations

from pathlib import Path
from typing import Iterator

import numpy as np

from ..blender_scripts.outputs import read_exr_rgba
from ..procedural.io import write_models, write_table
from ..procedural.render import _renderer, render_frame_fast
from ..procedural.scene import ProceduralScene
from ..synth.blender import render_job


def linear_to_srgb_u8(rgb_linear: np.ndarray) -> np.ndarray:
    """Linear RGB in [0, 1] -> sRGB uint8 (IEC 61966-2-1 transfer function)."""
    x = np.clip(np.asarray(rgb_linear, np.float64), 0.0, 1.0)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)
    return np.clip(np.round(s * 255.0), 0, 255).astype(np.uint8)


def srgb_u8_to_linear(rgb: np.ndarray) -> np.ndarray:
    x = np.asarray(rgb, np.float64) / 255.0
    return np.where(x <= 0.04045, x / 12.92, ((x + 0.055) / 1.055) ** 2.4)


def blender_job(scene: ProceduralScene, models_dir: Path, work_dir: Path, samples: int = 12,
                denoise: bool = True, with_table: bool = False, lights: list | None = None,
                world_strength: float | None = None) -> dict:
    """The render job dict (see ``ycbvss.synth.blender.render_job``) for all frames of ``scene``;
    ``lights`` / ``world_strength`` replace the Blender session's default lighting when given."""
    work_dir = Path(work_dir)
    if all(m.path is not None and Path(m.path).is_file() for m in scene.models.values()):
        paths = {oid: Path(m.path) for oid, m in scene.models.items()}     # models already on disk (BOP PLY)
    else:
        paths = write_models(scene, models_dir)
    meshes = {f"obj_{oid:06d}": {"path": str(p)} for oid, p in paths.items()}
    if with_table:
        meshes["table"] = {"path": str(write_table(scene, work_dir / "table" / "table.ply"))}
    frames = []
    for f in scene.frames:
        objs = [{"mesh": f"obj_{i.obj_id:06d}", "pass_index": int(i.obj_id), "T_m2c": np.asarray(i.T_m2c).tolist()}
                for i in f.instances]
        if with_table:
            objs.append({"mesh": "table", "pass_index": 0, "T_m2c": np.asarray(f.T_w2c).tolist()})
        frames.append({"id": f"{f.im_id:06d}", "K": np.asarray(f.camera.K).tolist(), "objects": objs,
                       "out_dir": str(work_dir / "frames"), "full_frame": bool(with_table)})
    job = {"width": scene.width, "height": scene.height, "samples": int(samples), "seed": int(scene.seed),
           "denoise": bool(denoise), "meshes": meshes, "frames": frames}
    if lights is not None:
        job["lights"] = lights
    if world_strength is not None:
        job["world_strength"] = float(world_strength)
    return job


def render_blender(scene: ProceduralScene, models_dir: str | Path, work_dir: str | Path, samples: int = 12,
                   denoise: bool = True, workers: int = 1, noise_sigma: float = 1.5, with_table: bool = False,
                   renderer=None, on_frame=None, lights: list | None = None,
                   world_strength: float | None = None, **settings) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """Render every frame with Blender; yield ``(im_id, rgb uint8, depth_mm float32)`` in frame order.

    ``models_dir`` receives the BOP model files (the scene's models then point at them);
    ``work_dir`` the table mesh and Blender's EXR/PNG outputs. ``noise_sigma``: Gaussian sensor
    noise (8-bit units) added after encoding. ``on_frame()`` is called as Blender finishes each
    frame (all frames are path traced before the first one is yielded). ``lights`` /
    ``world_strength``: see :func:`blender_job`. ``settings``: further Blender session settings
    (``material``, ``filter_width``: ``ycbvss.blender_scripts.session.BlenderSession.configure``)."""
    job = blender_job(scene, Path(models_dir), Path(work_dir), samples, denoise, with_table, lights, world_strength)
    job.update(settings)
    results = render_job(job, workers=workers, on_done=(lambda _r: on_frame()) if on_frame else None)
    r = _renderer(scene, renderer)
    bg = srgb_u8_to_linear(np.asarray(scene.background_rgb, np.float64))
    rng = np.random.default_rng(scene.seed + 7)
    for f, res in zip(scene.frames, results):
        rgba = read_exr_rgba(res["rgba"])
        a = np.clip(rgba[..., 3:4], 0.0, 1.0)
        _, depth, _ = render_frame_fast(scene, f, r)                     # exact depth, objects + table
        if with_table:
            under = bg
        else:
            table_rgb, _, _ = render_frame_fast(scene, f, r, with_objects=False)
            under = srgb_u8_to_linear(table_rgb)
        lin = rgba[..., :3] + (1.0 - a) * under          # premultiplied "over"
        rgb = linear_to_srgb_u8(lin)
        if noise_sigma > 0:
            rgb = np.clip(np.round(rgb + rng.normal(0, noise_sigma, rgb.shape)), 0, 255).astype(np.uint8)
        yield f.im_id, rgb, depth
