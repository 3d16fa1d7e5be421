"""Random initial deviations of exact poses, the starting points of refinement tests and benches
(their errors are measured with :mod:`ycbvss.eval.metrics`)."""
from __future__ import annotations

import numpy as np

from ..geometry.se3 import exp_se3


def deviate_scene(T_m2w: dict, T_w2c: dict, rng: np.random.Generator, t_sigma_mm=(3.0, 3.0, 20.0),
                  r_sigma_deg: float = 2.0, view_t_sigma_mm: float = 1.0, view_r_sigma_deg: float = 0.3) -> dict:
    """Initial poses {(im_id, obj_id): 4x4} = GT with a systematic per-object deviation (expressed in
    the first camera's axes, so tz is the depth error as in YCB-V) plus a per-view deviation in each
    view's camera axes (``view_t_sigma_mm`` scalar or (3,) per axis, ``view_r_sigma_deg``).

    The object is rotated about its own origin: T' = D T with D = [exp(w), t - exp(w) t + dt]."""
    im_ids = sorted(T_w2c)
    T0 = T_w2c[im_ids[0]]
    out = {}
    for oid, Tm in T_m2w.items():
        P0 = T0 @ Tm
        w = rng.normal(scale=np.radians(r_sigma_deg), size=3)
        dt = rng.normal(size=3) * np.asarray(t_sigma_mm)
        D = exp_se3(np.r_[0, 0, 0, w])
        P0d = P0.copy()
        P0d[:3, :3] = D[:3, :3] @ P0[:3, :3]
        P0d[:3, 3] = P0[:3, 3] + dt
        Tm_d = np.linalg.inv(T0) @ P0d
        for im in im_ids:
            P = T_w2c[im] @ Tm_d
            J = exp_se3(np.r_[rng.normal(size=3) * np.broadcast_to(np.asarray(view_t_sigma_mm, float), (3,)),
                              rng.normal(scale=np.radians(view_r_sigma_deg), size=3)])
            Pj = P.copy()
            Pj[:3, :3] = J[:3, :3] @ P[:3, :3]
            Pj[:3, 3] = P[:3, 3] + J[:3, 3]
            out[(im, oid)] = Pj
    return out
