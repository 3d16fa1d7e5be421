"""The image motion the current scene estimate predicts between two views, for f_t's flow.

f_t matches points of view k into view i by dense Farneback flow between the two real images. The
keyframes of a long clip are about 7.5 degrees apart and their images move by 20-60 px. Measured
on suite scene 1 with ``bench/bench_temporal_flow.py`` (exact correspondences from Blender's depth):

- from a zero start, 26 % of the matches that pass the forward-backward check on pairs 25 frames
  apart are more than 2 px wrong (flow that stayed near zero both ways), and only the slower half of
  the scene is matched; pairs 1-8 frames apart (1-11 px) are matched to 0.06-0.15 px;
- Farneback's smoothing also compresses the motion differences between near and far points (the
  parallax that carries depth): the error along the motion falls by 0.01-0.02 px per px a point
  moves faster than the median (25-frame pairs), and a small near object takes its background's
  motion (``tests/test_flow_prior.py``: a 20 px square moving 30 px over a background moving 22 px
  gets 21.2 px even when Farneback starts from the right motion).

On long clip 1's eight keyframes refined from the exact GT this moves the whole scene towards the
cameras: mean dz -0.70 mm with f_t, +1.24 mm without it, +1.17 mm with f_t fed the exact
correspondences. ``RefineOptions.flow_prior``:

- ``True``: Farneback starts from :func:`predicted_flow` (``cv2.OPTFLOW_USE_INITIAL_FLOW``): 1 % of
  the matches > 2 px wrong, but the compression stays and the shift grows (-1.53 mm);
- ``"residual"``: the second image is warped by the prediction and Farneback finds only the residual
  (:func:`ycbvss.refine.matching.residual_flow_pair`), predicted at the finest blur level only
  (``RefineOptions.flow_prior_levels``; at the coarser levels the estimate, and so its prediction,
  is still centimetres off). With the
  predicting camera 0.3 deg / 3 mm off, the 25-frame pairs' matches are 0.11 px off (median; 0.37
  started from the prediction, 0.51 from zero) with no compression (slope 0.000 px/px against
  -0.014 and, with its outliers, -1.4), the 8-frame pairs' 0.08 px (0.15). From the exact GT on long-1's keyframes:
  +1.06 mm, f_t no longer moves the scene; what is left is the edges' recession (see the README).

Alone, it makes things worse: removing f_t's pull uncovers the edges' opposite bias, so on long-1
the depth error grows (from the exact GT |dz| 0.70 -> 1.06 mm; from the paper's initial error on the
keyframes tz 1.17 -> 1.21 mm). With ``RefineOptions.edge_appearance`` as well: 0.65 and 0.72 mm.
Since session 36 it is on for medium and wide scenes together with the other appearance
corrections (``RefineOptions.bias_removal_groups``).
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
