"""The image motion the current scene estimate predicts between two views: a warm start for f_t's flow.

f_t matches points of view k into view i by dense Farneback flow between the two real images. The
keyframes of a long clip are about 7.5 degrees apart and their images move by 20-60 px, beyond what
a three-level Farneback pyramid follows from a zero start. Measured on suite scene 1 with
``bench/bench_temporal_flow.py`` (pairs 25 frames apart, exact correspondences from Blender's
depth): from zero, 26 % of the matches that pass the forward-backward check are more than 2 px
wrong (mostly flow that stayed near zero in both directions) and only the slower half of the scene
is matched; started from :func:`predicted_flow`, 1 % are, with no mean error along the motion.
Pairs 1-8 frames apart (1-11 px) are matched equally well from either start.

Off by default (``RefineOptions.flow_prior``): on long clip 1's eight keyframes, refined from the
exact GT, f_t moves the whole scene towards the cameras with either start (mean dz -0.70 mm from
zero, -1.53 mm warm-started; without f_t +1.24 mm; with f_t fed the exact correspondences +1.17 mm),
so the better matches do not remove f_t's depth bias on wide keyframe pairs; they make it larger.
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import distance_transform_edt

from ..geometry.se3 import inv_T


def predicted_flow(depth_mm: np.ndarray, K_src: np.ndarray, K_dst: np.ndarray, T_src2dst: np.ndarray,
                   box: tuple[int, int, int, int] | None = None) -> np.ndarray:
    """Flow (h, w, 2) float32 (px, u then v) from a source view to a destination view predicted by
    the source's rendered depth ``depth_mm`` (H, W; 0 where nothing is rendered), the intrinsics
    and the rigid motion ``T_src2dst`` (4x4, mm; source-camera to destination-camera coordinates).
    Pixels without depth take the flow of the nearest pixel with depth; with no depth at all the
    flow is zero. ``box`` = (y0, y1, x0, x1): only that crop (its pixel coordinates stay the full
    image's)."""
    y0, y1, x0, x1 = box if box is not None else (0, depth_mm.shape[0], 0, depth_mm.shape[1])
    D = np.asarray(depth_mm[y0:y1, x0:x1], dtype=np.float64)
    h, w = D.shape
    has = D > 0
    F = np.zeros((h, w, 2), np.float32)
    if not has.any():
        return F
    v, u = np.nonzero(has)
    z = D[v, u]
    Ki = np.linalg.inv(K_src)
    rays = Ki @ np.stack([u + x0, v + y0, np.ones(len(u))])
    Y = T_src2dst[:3, :3] @ (rays * z) + T_src2dst[:3, 3:4]
    q = K_dst @ Y
    zq = np.where(np.abs(q[2]) > 1e-9, q[2], 1e-9)
    F[v, u, 0] = q[0] / zq - (u + x0)
    F[v, u, 1] = q[1] / zq - (v + y0)
    if not has.all():
        _, (iy, ix) = distance_transform_edt(~has, return_indices=True)
        F = F[iy, ix]
    return np.ascontiguousarray(F, dtype=np.float32)


def relative_motion(T_w2c_src: np.ndarray, T_w2c_dst: np.ndarray) -> np.ndarray:
    """Source-camera to destination-camera coordinates (4x4, mm) from two world-to-camera poses."""
    return T_w2c_dst @ inv_T(T_w2c_src)
