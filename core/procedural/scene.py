"""`make_scene`: a procedural multi-object table-top scene with exact poses (no data needed).

Five objects (obj_ids 1..5) stand on a textured table: two boxes, two cylinders and a mug
(cup + handle). Objects 1, 3, 4 carry procedural textures; 2 (box) and 5 (mug) are
textureless (uniform colour; marked ``textureless=True`` like the starred YCB-V objects).
The camera (YCB-V "uw" intrinsics scaled to the image size) sweeps a smooth arc of
``arc_deg`` degrees around the objects at 0.6-1.0 m, so neighbouring objects occlude each
other in some views and the views have a real multi-view baseline.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import trimesh

from ..camera import Camera
from ..geometry.se3 import compose, inv_T, transform_points
from ..io.mesh import diameter_mm
from ..scene import Frame, Instance, ObjectModel, Scene
from . import shapes, textures
from .layout import YCBV_UW_K, arc_trajectory, baseline_deg, place_on_table, scaled_K

OBJECT_NAMES = {1: "box_checker", 2: "box_plain*", 3: "can_stripes", 4: "can_text", 5: "mug_plain*"}


@dataclass
class ProceduralScene:
    """A procedural scene: models (obj_id -> ObjectModel, meshes in memory), frames with exact
    GT, the table (not a GT object) and world poses. World frame: z up, table top at z = 0 (mm)."""

    models: dict[int, ObjectModel]
    frames: list[Frame]
    T_m2w: dict[int, np.ndarray]
    table_mesh: trimesh.Trimesh
    light_dir_w: np.ndarray
    width: int
    height: int
    seed: int
    scene_id: int = 1
    target_w: np.ndarray = field(default_factory=lambda: np.zeros(3))
    background_rgb: tuple[int, int, int] = (70, 74, 80)

    @property
    def scene(self) -> Scene:
        """The frames as a :class:`ycbvss.scene.Scene` (no image paths until written to disk)."""
        return Scene(self.scene_id, self.frames)

    @property
    def baseline_deg(self) -> float:
        return baseline_deg([f.T_w2c for f in self.frames], self.target_w)


def _make_models(rng: np.random.Generator) -> dict[int, ObjectModel]:
    def jitter(x: float, rel: float = 0.1) -> float:
        return float(x * (1 + rng.uniform(-rel, rel)))

    meshes = {
        1: (shapes.box((jitter(170), jitter(110), jitter(60)), textures.checker_labels(rng)), False),
        2: (shapes.box((jitter(90), jitter(70), jitter(170)), textures.plain(rng.uniform(0.55, 0.8, 3))), True),
        3: (shapes.cylinder(jitter(40), jitter(120), textures.stripes(rng)), False),
        4: (shapes.cylinder(jitter(34), jitter(95), textures.text_blobs(rng)), False),
        5: (shapes.mug(jitter(42), jitter(100), 5.0, textures.plain((0.75, 0.18, 0.15))), True),
    }
    models = {}
    for oid, (mesh, textureless) in meshes.items():
        m = ObjectModel(obj_id=oid, path=None, name=OBJECT_NAMES[oid], unit_scale=1.0,
                        diameter_mm=diameter_mm(mesh.vertices), textureless=textureless)
        m.mesh = mesh
        models[oid] = m
    return models


def _fit_distance(models, T_m2w, target, K, width, height, n_frames, elevation_deg, az0, arc_deg,
                  d_min=600.0, d_max=1000.0, margin_px=6.0) -> float:
    """Smallest camera distance in [d_min, d_max] at which every object's bounding box projects
    inside the image (with a margin) in every frame."""
    corners = []
    for oid, m in models.items():
        lo, hi = m.mesh.bounds
        c = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        corners.append(transform_points(T_m2w[oid], c))
    corners = np.concatenate(corners)
    for d in np.arange(d_min, d_max + 1e-6, 20.0):
        ok = True
        for T in arc_trajectory(n_frames, target, d, elevation_deg, az0, arc_deg):
            X = transform_points(T, corners)
            uv = X[:, :2] / X[:, 2:3] @ K[:2, :2].T + K[:2, 2]
            if (uv.min() < margin_px or uv[:, 0].max() > width - 1 - margin_px
                    or uv[:, 1].max() > height - 1 - margin_px):
                ok = False
                break
        if ok:
            return float(d)
    return float(d_max)


def make_scene(seed: int = 0, n_frames: int = 24, width: int = 640, height: int = 480,
               arc_deg: float = 50.0, elevation_deg: float = 32.0, scene_id: int = 1) -> ProceduralScene:
    """Build the procedural scene for ``seed`` (deterministic).

    ``n_frames`` camera poses on an arc of ``arc_deg`` degrees (baseline), elevation about
    ``elevation_deg``; images ``width`` x ``height`` with the YCB-V uw intrinsics scaled to that
    size. Every frame lists all five objects with exact ``T_m2c`` (mm).
    """
    if n_frames < 2:
        raise ValueError("n_frames must be >= 2")
    if width < 32 or height < 24:
        raise ValueError("image too small (min 32 x 24)")
    rng = np.random.default_rng(seed)
    models = _make_models(rng)
    fps = [np.asarray(m.mesh.vertices)[:, :2] for m in models.values()]
    hs = [float(np.ptp(np.asarray(m.mesh.vertices)[:, 2])) for m in models.values()]
    T_list = place_on_table(fps, hs, rng, region_radius_mm=150.0, gap_mm=10.0)
    T_m2w = {oid: T for oid, T in zip(models, T_list)}
    table = shapes.table(2400.0, textures.wood(rng), repeats=3.0)
    K = scaled_K(YCBV_UW_K, width, height)
    target = np.array([0.0, 0.0, 50.0])
    az0 = float(rng.uniform(0, 360))
    el = float(elevation_deg + rng.uniform(-3, 3))
    dist = _fit_distance(models, T_m2w, target, K, width, height, n_frames, el, az0, arc_deg)
    cams = arc_trajectory(n_frames, target, dist, el, az0, arc_deg)
    cam = Camera(K, width, height)
    frames = []
    for im_id, T_w2c in enumerate(cams):
        inst = [Instance(obj_id=oid, T_m2c=compose(T_w2c, T_m2w[oid]), gt_id=k)
                for k, oid in enumerate(models)]
        frames.append(Frame(scene_id=scene_id, im_id=im_id, camera=Camera(cam.K.copy(), width, height),
                            instances=inst, depth_scale=0.1, T_w2c=T_w2c))
    light = np.array([0.4, -0.3, 1.0])
    return ProceduralScene(models=models, frames=frames, T_m2w=T_m2w, table_mesh=table,
                           light_dir_w=light / np.linalg.norm(light), width=width, height=height,
                           seed=seed, scene_id=scene_id, target_w=target)


def T_table2c(scene: ProceduralScene, frame: Frame) -> np.ndarray:
    """Table pose in the camera frame (the table's model frame is the world frame)."""
    return np.asarray(frame.T_w2c, np.float64)


__all__ = ["ProceduralScene", "make_scene", "OBJECT_NAMES", "T_table2c", "inv_T"]
