"""Pure geometry of a procedural scene: object placement on a table, camera trajectory."""
from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull

from ..geometry.se3 import inv_T, make_T

# YCB-Video "uw" camera (videos 0000-0059) at 640 x 480.
YCBV_UW_K = np.array([[1066.778, 0.0, 312.9869], [0.0, 1067.487, 241.3109], [0.0, 0.0, 1.0]])


def scaled_K(K: np.ndarray, width: int, height: int, ref_size: tuple[int, int] = (640, 480)) -> np.ndarray:
    """Intrinsics of a 640x480 camera for an image of size (width, height), pixel centres exact."""
    sx, sy = width / ref_size[0], height / ref_size[1]
    K2 = np.array(K, np.float64).copy()
    K2[0, 0] *= sx
    K2[0, 1] *= sx
    K2[1, 1] *= sy
    K2[0, 2] = (K[0, 2] + 0.5) * sx - 0.5
    K2[1, 2] = (K[1, 2] + 0.5) * sy - 0.5
    return K2


def rot_z(angle_rad: float) -> np.ndarray:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def place_on_table(footprints_mm: list[np.ndarray], heights_mm: list[float], rng: np.random.Generator,
                   region_radius_mm: float = 170.0, gap_mm: float = 8.0, max_tries: int = 20000) -> list[np.ndarray]:
    """Place objects upright on the table z = 0 at random yaw and position without overlap.

    ``footprints_mm[k]``: (N, 2) model-frame x/y of object k's vertices (model z is up, model
    bottom at z = -heights_mm[k]/2). Objects are accepted when their footprint polygons (convex
    hulls after yaw) are separated by ``gap_mm`` -- tested with the separating-axis theorem.
    Returns T_m2w (4x4, mm) per object. Larger objects are placed first.
    """
    hulls = [fp[ConvexHull(fp).vertices] for fp in footprints_mm]
    order = np.argsort([-np.ptp(h, axis=0).prod() for h in hulls])
    placed: dict[int, np.ndarray] = {}
    poly_w: dict[int, np.ndarray] = {}
    for k in order:
        for _ in range(max_tries):
            yaw = rng.uniform(-np.pi, np.pi)
            r = region_radius_mm * np.sqrt(rng.random())
            phi = rng.uniform(-np.pi, np.pi)
            xy = np.array([r * np.cos(phi), r * np.sin(phi)])
            P = hulls[k] @ rot_z(yaw)[:2, :2].T + xy
            if all(_separated(P, Q, gap_mm) for Q in poly_w.values()):
                placed[k] = make_T(rot_z(yaw), np.array([xy[0], xy[1], heights_mm[k] / 2.0]))
                poly_w[k] = P
                break
        else:
            raise RuntimeError("could not place objects without overlap; enlarge region_radius_mm")
    return [placed[k] for k in range(len(footprints_mm))]


def _separated(P: np.ndarray, Q: np.ndarray, gap: float) -> bool:
    """True if convex polygons P, Q (counter-clockwise (N, 2)) are at least ``gap`` apart along some edge normal."""
    for poly in (P, Q):
        e = np.roll(poly, -1, axis=0) - poly
        n = np.stack([e[:, 1], -e[:, 0]], 1)
        n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-12
        pp, qq = P @ n.T, Q @ n.T
        if np.any((pp.min(0) - qq.max(0) >= gap) | (qq.min(0) - pp.max(0) >= gap)):
            return True
    return False


def look_at(eye_mm: np.ndarray, target_mm: np.ndarray, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """World-to-camera T (OpenCV axes: z forward, x right, y down) of a camera at ``eye`` looking at ``target``."""
    z = np.asarray(target_mm, float) - np.asarray(eye_mm, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, np.asarray(up, float))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R_c2w = np.stack([x, y, z], axis=1)
    return inv_T(make_T(R_c2w, np.asarray(eye_mm, float)))


def arc_trajectory(n_frames: int, target_mm: np.ndarray, distance_mm: float, elevation_deg: float,
                   azimuth_start_deg: float, arc_deg: float, wobble_deg: float = 4.0,
                   distance_wobble_mm: float = 40.0) -> list[np.ndarray]:
    """Camera poses T_w2c on a smooth arc around ``target`` (azimuth sweep ``arc_deg``, gentle
    elevation and distance variation, as a hand-held sweep). Returns n_frames 4x4 matrices."""
    s = np.linspace(0.0, 1.0, n_frames)
    az = np.radians(azimuth_start_deg + arc_deg * s)
    el = np.radians(elevation_deg + wobble_deg * np.sin(2 * np.pi * s))
    d = distance_mm + distance_wobble_mm * np.sin(np.pi * s + 0.3)
    out = []
    for a, e, dd in zip(az, el, d):
        eye = np.asarray(target_mm, float) + dd * np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
        out.append(look_at(eye, target_mm))
    return out


def camera_centre(T_w2c: np.ndarray) -> np.ndarray:
    return inv_T(T_w2c)[:3, 3]


def baseline_deg(T_w2c_list: list[np.ndarray], target_mm: np.ndarray) -> float:
    """Largest angle (deg) between the viewing directions from ``target`` to any two camera centres."""
    c = np.stack([camera_centre(T) - target_mm for T in T_w2c_list])
    c /= np.linalg.norm(c, axis=1, keepdims=True)
    cosang = np.clip(c @ c.T, -1.0, 1.0)
    return float(np.degrees(np.arccos(cosang.min())))
