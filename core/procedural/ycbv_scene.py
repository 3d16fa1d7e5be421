"""Table-top scenes of the real YCB-V object models with exact poses (the refiner's validation suite).

A scene holds 4-7 YCB-V objects resting on a textured table in one of their stable poses
(trimesh's quasi-static stable poses of the mesh), at random yaw, packed closely (touching or a
few millimetres apart) so that they occlude each other as in YCB-V; a small object may be stacked
on the top face of a box. The camera follows a slow hand-held path around the objects: a smooth
arc of ``arc_deg`` degrees with a random-walk wobble, 0.5-1.5 m from the objects. Pure geometry:
the images are rendered elsewhere (Blender, :mod:`ycbvss.pipeline.blender_scene`).
"""
from __future__ import annotations

import numpy as np
import trimesh
from scipy.spatial import ConvexHull

from ..camera import Camera
from ..geometry.se3 import compose, inv_T, make_T, transform_points
from ..geometry.so3 import exp_so3
from ..scene import Frame, Instance, ObjectModel
from . import shapes, textures
from .layout import YCBV_UW_K, _separated, look_at, rot_z, scaled_K
from .scene import ProceduralScene

# objects with a flat top a small object can be stacked on, and small objects that can go there
STACK_BASES = (2, 3, 7, 8, 9, 16, 18)          # 003, 004, 008, 009, 036, 040... (boxes, the wood block)
STACK_SMALL = (6, 8, 9, 10, 18, 21)            # tuna can, pudding, gelatin, potted meat, marker, foam brick


def rest_poses(mesh: trimesh.Trimesh, min_prob: float = 0.08, max_n: int = 3) -> list[tuple[np.ndarray, float]]:
    """Stable resting poses of a mesh on the plane z = 0: ``[(T_rest 4x4 mm, probability), ...]``,
    most probable first, the mesh's lowest point on z = 0 (trimesh's quasi-static estimate on the
    convex hull)."""
    hull = mesh.convex_hull
    T, p = trimesh.poses.compute_stable_poses(hull, n_samples=1, threshold=0.0, sigma=0.0)
    out = []
    for Ti, pi in sorted(zip(T, p), key=lambda x: -x[1]):
        if pi < min_prob and out:
            continue
        Ti = np.asarray(Ti, np.float64).copy()
        z = transform_points(Ti, np.asarray(hull.vertices))[:, 2]
        Ti[2, 3] -= z.min()
        out.append((Ti, float(pi)))
        if len(out) >= max_n:
            break
    return out


def _hull2d(xy: np.ndarray) -> np.ndarray:
    return xy[ConvexHull(xy).vertices]


def place_objects(models: dict[int, ObjectModel], obj_ids: list[int], rng: np.random.Generator,
                  region_radius_mm: float | None = None, gap_mm: tuple[float, float] = (0.5, 12.0),
                  p_stack: float = 0.5, max_tries: int = 20000) -> tuple[dict[int, np.ndarray], dict]:
    """World poses T_m2w (mm; table top z = 0, z up) of ``obj_ids`` resting on the table.

    Larger footprints first; each object takes a random stable pose (weighted by its
    probability), yaw and position within ``region_radius_mm``, accepted when its footprint
    polygon is at least a random gap in ``gap_mm`` from every placed one (the smallest gaps make
    objects nearly touch). With probability ``p_stack`` one small object is stacked on the top
    face of a box-like object. Returns (T_m2w, info: rest-pose index, stacked-on per object)."""
    meshes = {o: models[o].mesh for o in obj_ids}
    rests = {o: rest_poses(meshes[o]) for o in obj_ids}
    choice = {}
    for o in obj_ids:
        p = np.array([r[1] for r in rests[o]])
        choice[o] = int(rng.choice(len(p), p=p / p.sum()))
    verts = {o: transform_points(rests[o][choice[o]][0], np.asarray(meshes[o].vertices)) for o in obj_ids}
    hulls = {o: _hull2d(verts[o][:, :2]) for o in obj_ids}
    info: dict = {"rest_pose": dict(choice), "stacked_on": {}}
    order = sorted(obj_ids, key=lambda o: -np.ptp(hulls[o], axis=0).prod())
    stack = _stack_pair(order, hulls, rng, p_stack)
    if region_radius_mm is None:    # packed: the footprints cover about half of the region
        area = sum(float(np.prod(np.ptp(hulls[o], axis=0))) for o in obj_ids if stack is None or o != stack[0])
        region_radius_mm = float(np.sqrt(2.0 * area / np.pi))
    rest = {o: rests[o][choice[o]][0] for o in obj_ids}
    placed: dict[int, np.ndarray] = {}
    poly: dict[int, np.ndarray] = {}
    for o in order:
        if stack is not None and o == stack[0]:
            continue
        placed[o], poly[o], region_radius_mm = _place_one(hulls[o], rest[o], poly, rng, region_radius_mm, gap_mm,
                                                         max_tries)
    if stack is not None:
        s, b = stack
        placed[s] = _stacked_pose(np.asarray(meshes[b].vertices), placed[b], verts[s], rest[s], rng)
        info["stacked_on"][s] = b
    return placed, info


def _stack_pair(order: list[int], hulls: dict, rng: np.random.Generator, p_stack: float) -> tuple | None:
    """(small object, box-like base) to stack, with probability ``p_stack`` when a base's footprint
    is wide enough (its shortest side > 0.8 x the small one's longest), else None."""
    bases = [o for o in order if o in STACK_BASES]
    smalls = [o for o in order if o in STACK_SMALL]
    if bases and rng.random() < p_stack:
        for s in reversed(smalls):
            base = next((b for b in bases
                         if b != s and np.ptp(hulls[b], axis=0).min() > 0.8 * np.ptp(hulls[s], axis=0).max()), None)
            if base is not None:
                return s, base
    return None


def _place_one(hull: np.ndarray, rest: np.ndarray, poly: dict, rng: np.random.Generator, region_radius_mm: float,
               gap_mm: tuple[float, float], max_tries: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Draw yaw and position (within the region, which grows by 10 % every 2000 tries) until the
    footprint ``hull`` (K, 2) mm keeps a random gap from every placed footprint in ``poly``.
    Returns (T_m2w 4x4 mm, placed footprint (K, 2), the region radius now)."""
    for k in range(max_tries):
        if k and k % 2000 == 0:
            region_radius_mm *= 1.1
        yaw = rng.uniform(-np.pi, np.pi)
        r = region_radius_mm * np.sqrt(rng.random())
        phi = rng.uniform(-np.pi, np.pi)
        xy = np.array([r * np.cos(phi), r * np.sin(phi)])
        P = hull @ rot_z(yaw)[:2, :2].T + xy
        gap = rng.uniform(*gap_mm)
        if all(_separated(P, Q, gap) for Q in poly.values()):
            return make_T(rot_z(yaw), np.array([xy[0], xy[1], 0.0])) @ rest, P, region_radius_mm
    raise RuntimeError("could not place the objects without overlap; enlarge region_radius_mm")


def _stacked_pose(base_vertices: np.ndarray, T_base: np.ndarray, verts_s: np.ndarray, rest_s: np.ndarray,
                  rng: np.random.Generator) -> np.ndarray:
    """T_m2w (mm) of a small object (``verts_s`` (N, 3) in its rest pose ``rest_s``) standing 0.5 mm
    above the centre of the top face of the base placed at ``T_base``, at a random yaw."""
    Vb = transform_points(T_base, base_vertices)
    top = float(Vb[:, 2].max())
    top_pts = Vb[Vb[:, 2] > top - 3.0]
    c = top_pts[:, :2].mean(axis=0)
    yaw = rng.uniform(-np.pi, np.pi)
    c_s = verts_s[:, :2].mean(axis=0)
    T = make_T(rot_z(yaw), np.zeros(3)) @ rest_s
    T[:3, 3] += np.array([c[0], c[1], top + 0.5]) - np.r_[rot_z(yaw)[:2, :2] @ c_s, 0.0]
    return T


def hand_held_path(n_frames: int, target_mm: np.ndarray, distance_mm: float, elevation_deg: float,
                   azimuth_start_deg: float, arc_deg: float, rng: np.random.Generator,
                   wobble_deg: float = 0.4, wobble_mm: float = 6.0) -> list[np.ndarray]:
    """T_w2c (mm) of a slow hand-held sweep: an arc of ``arc_deg`` around ``target`` (azimuth),
    gently varying elevation and distance, plus a smooth random wobble of the viewing direction
    (``wobble_deg``) and position (``wobble_mm``), as YCB-V's videos show."""
    s = np.linspace(0.0, 1.0, n_frames)
    az = np.radians(azimuth_start_deg + arc_deg * s)
    el = np.radians(elevation_deg + 3.0 * np.sin(2 * np.pi * s + rng.uniform(0, 6.3)))
    d = distance_mm + 0.06 * distance_mm * np.sin(np.pi * s + rng.uniform(0, 6.3))

    def smooth_walk(dim: int, scale: float) -> np.ndarray:
        w = np.cumsum(rng.normal(size=(n_frames, dim)), axis=0)
        k = np.hanning(15)
        w = np.stack([np.convolve(np.pad(w[:, i], 7, mode="edge"), k / k.sum(), mode="valid") for i in range(dim)], 1)
        w -= w.mean(axis=0)
        return scale * w / max(float(np.abs(w).max()), 1e-9)

    rot_w = smooth_walk(3, np.radians(wobble_deg))
    pos_w = smooth_walk(3, wobble_mm)
    out = []
    for k in range(n_frames):
        eye = np.asarray(target_mm, float) + d[k] * np.array([np.cos(el[k]) * np.cos(az[k]),
                                                             np.cos(el[k]) * np.sin(az[k]), np.sin(el[k])])
        T = look_at(eye + pos_w[k], target_mm)
        R = exp_so3(rot_w[k])
        out.append(make_T(R, np.zeros(3)) @ T)
    return out


def _fits(corners_w: np.ndarray, cams: list[np.ndarray], K: np.ndarray, width: int, height: int,
          margin_px: float) -> bool:
    for T in cams:
        X = transform_points(T, corners_w)
        if np.any(X[:, 2] <= 0):
            return False
        uv = X[:, :2] / X[:, 2:3] @ K[:2, :2].T + K[:2, 2]
        if uv.min() < margin_px or uv[:, 0].max() > width - 1 - margin_px or uv[:, 1].max() > height - 1 - margin_px:
            return False
    return True


def make_ycbv_scene(models: dict[int, ObjectModel], obj_ids: list[int], seed: int, n_frames: int = 200,
                    arc_deg: float = 60.0, width: int = 640, height: int = 480, scene_id: int = 1,
                    distance_mm: tuple[float, float] = (550.0, 1300.0),
                    elevation_deg: tuple[float, float] = (22.0, 42.0)) -> ProceduralScene:
    """A YCB-V table-top scene (deterministic for ``seed``): ``obj_ids`` placed by
    :func:`place_objects`, ``n_frames`` views on a hand-held path of ``arc_deg`` degrees. The camera
    distance starts at a random value in ``distance_mm`` and grows (up to 1.5 m) until every
    object's bounding box is in every image; YCB-V uw intrinsics scaled to ``width`` x ``height``."""
    rng = np.random.default_rng(seed)
    T_m2w, info = place_objects(models, obj_ids, rng)
    corners = []
    for o in obj_ids:
        lo, hi = models[o].mesh.bounds
        c = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
        corners.append(transform_points(T_m2w[o], c))
    corners = np.concatenate(corners)
    target = np.r_[0.5 * (corners[:, :2].min(0) + corners[:, :2].max(0)), 0.35 * corners[:, 2].max()]
    K = scaled_K(YCBV_UW_K, width, height)
    az0 = float(rng.uniform(0, 360))
    el = float(rng.uniform(*elevation_deg))
    d0 = float(rng.uniform(*distance_mm))
    path_seed = int(rng.integers(2 ** 31))
    cams = None
    for d in np.arange(d0, 1500.0 + 1e-6, 25.0):
        cams = hand_held_path(n_frames, target, float(d), el, az0, arc_deg, np.random.default_rng(path_seed))
        if _fits(corners, cams, K, width, height, 8.0):
            break
    table = shapes.table(2400.0, textures.wood(rng), repeats=3.0)
    frames = []
    for im_id, T_w2c in enumerate(cams):
        inst = [Instance(obj_id=o, T_m2c=compose(T_w2c, T_m2w[o]), gt_id=k) for k, o in enumerate(obj_ids)]
        frames.append(Frame(scene_id=scene_id, im_id=im_id, camera=Camera(K.copy(), width, height),
                            instances=inst, depth_scale=0.1, T_w2c=T_w2c))
    light = np.array([0.3, -0.4, 1.0])
    sc = ProceduralScene(models={o: models[o] for o in obj_ids}, frames=frames, T_m2w=T_m2w, table_mesh=table,
                         light_dir_w=light / np.linalg.norm(light), width=width, height=height, seed=seed,
                         scene_id=scene_id, target_w=target, background_rgb=(70, 74, 80))
    sc.layout = info        # rest-pose choice and stacking, for the suite's report
    return sc


def camera_distance_mm(scene: ProceduralScene) -> np.ndarray:
    """Distance (mm) from each frame's camera centre to each object's origin, (n_frames, n_objects)."""
    C = np.stack([inv_T(f.T_w2c)[:3, 3] for f in scene.frames])
    P = np.stack([scene.T_m2w[o][:3, 3] for o in sorted(scene.T_m2w)])
    return np.linalg.norm(C[:, None] - P[None], axis=2)
