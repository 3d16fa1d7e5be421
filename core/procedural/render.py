"""Fast (OpenGL) rendering of a procedural scene with simple Lambertian shading.

This is the cheap stand-in for Blender: textured albedo x (ambient + diffuse * max(0, n.l)) with
one directional light fixed in the world (so shading is consistent across views), the table
as background and a flat colour where nothing is hit. Exact depth in mm comes with it.
"""
from __future__ import annotations

from typing import Iterator

import numpy as np

from ..render import Renderer
from .scene import ProceduralScene

TABLE_KEY = "procedural_table"


def _renderer(scene: ProceduralScene, renderer=None):
    r = renderer if renderer is not None else Renderer()
    for oid, m in scene.models.items():
        key = ("procedural", scene.seed, oid)
        if not r.has_mesh(key):
            r.add_mesh(key, m.mesh)
    if not r.has_mesh((TABLE_KEY, scene.seed)):
        r.add_mesh((TABLE_KEY, scene.seed), scene.table_mesh)
    return r


def render_frame_fast(scene: ProceduralScene, frame, renderer=None, ambient: float = 0.35,
                      diffuse: float = 0.75, noise_sigma: float = 0.0, rng: np.random.Generator | None = None,
                      with_table: bool = True, with_objects: bool = True):
    """Render one frame: returns (rgb uint8 (H,W,3), depth_mm float32 (H,W), instance int32 (H,W))
    where ``instance`` is obj_id per pixel (0 = table/background)."""
    r = _renderer(scene, renderer)
    insts = frame.instances if with_objects else []
    items = [(("procedural", scene.seed, i.obj_id), i.T_m2c) for i in insts]
    if with_table:
        items.append(((TABLE_KEY, scene.seed), frame.T_w2c))
    cam = frame.camera
    out = r.render(cam.K, cam.width, cam.height, items, outputs=("depth", "instance", "normal", "color"),
                   zfar_mm=10000.0)
    l_c = np.asarray(frame.T_w2c)[:3, :3] @ scene.light_dir_w
    nl = np.clip(out.normal_cam @ l_c, 0.0, 1.0)
    shade = ambient + diffuse * nl
    rgb = out.color.astype(np.float32) * shade[..., None]
    bg = out.instance == 0
    rgb[bg] = scene.background_rgb
    if noise_sigma > 0:
        rng = rng if rng is not None else np.random.default_rng(scene.seed * 1000 + frame.im_id)
        rgb = rgb + rng.normal(0.0, noise_sigma, rgb.shape)
    rgb = np.clip(np.round(rgb), 0, 255).astype(np.uint8)
    inst_ids = np.array([0] + [i.obj_id for i in insts] + ([0] if with_table else []), np.int32)
    obj_map = inst_ids[out.instance]
    depth = out.depth_mm.astype(np.float32)
    return rgb, depth, obj_map


def render_fast(scene: ProceduralScene, renderer=None, noise_sigma: float = 1.5
                ) -> Iterator[tuple[int, np.ndarray, np.ndarray]]:
    """Yield ``(im_id, rgb uint8 (H,W,3), depth_mm float32 (H,W))`` for every frame of ``scene``."""
    r = _renderer(scene, renderer)
    for f in scene.frames:
        rgb, depth, _ = render_frame_fast(scene, f, r, noise_sigma=noise_sigma)
        yield f.im_id, rgb, depth
