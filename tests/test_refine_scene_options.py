"""RefineOptions.wide_bias_removal: which scenes get WIDE_BIAS_REMOVAL (refine.bundle._scene_options)."""
from types import SimpleNamespace

import numpy as np

from ycbvss.refine.bundle import WIDE_BIAS_REMOVAL, RefineOptions, _scene_options


def _orbit(angles_deg: list[float], dist_mm: float = 1000.0) -> np.ndarray:
    """Cameras (world -> camera) on a circle about the origin, each looking at it."""
    T = []
    for a in np.radians(angles_deg):
        c = np.array([dist_mm * np.sin(a), 0.0, -dist_mm * np.cos(a)])     # camera centre
        z = -c / np.linalg.norm(c)
        x = np.cross([0.0, 1.0, 0.0], z)
        x /= np.linalg.norm(x)
        R = np.stack([x, np.cross(z, x), z])                                 # rows: camera axes in the world
        M = np.eye(4)
        M[:3, :3], M[:3, 3] = R, -R @ c
        T.append(M)
    return np.array(T)


def _pb(angles_deg):
    T_m = np.tile(np.eye(4), (3, 1, 1))
    T_m[:, :3, 3] = [[0, 0, 0], [80, 0, 0], [-60, 40, 0]]
    return SimpleNamespace(T_c=_orbit(angles_deg), T_m=T_m)


def test_wide_scenes_get_every_bias_removal_and_narrow_ones_keep_their_options():
    known = np.ones(3, bool)
    opt = RefineOptions(wide_bias_removal=True)
    stats: dict = {}
    wide = _scene_options(opt, _pb([0, 20, 40, 60]), [0, 1, 2, 3], known, stats)
    assert stats["wide_bias_removal"] is True
    for k, v in WIDE_BIAS_REMOVAL.items():
        assert getattr(wide, k) == v and getattr(opt, k) != v      # the caller's options untouched
    for angles in ([0, 3, 6], [0, 10, 20]):                          # narrow (< 10 deg) and medium (< 35)
        stats = {}
        assert _scene_options(opt, _pb(angles), [0, 1, 2], known, stats) is opt
        assert stats["wide_bias_removal"] is False
    stats = {}
    off = RefineOptions(wide_bias_removal=False)
    assert _scene_options(off, _pb([0, 20, 40, 60]), [0, 1, 2, 3], known, stats) is off
