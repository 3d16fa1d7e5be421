"""bench/bench_bias_lighting.py's lights fixed in the world: each frame's light direction (in that
frame's camera) is the first frame's direction carried through the camera motion, so the direction
in the world stays the same while the camera turns."""
import importlib.util
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

_bench = Path(__file__).parents[1] / "bench"
_spec = importlib.util.spec_from_file_location("bench_bias_lighting", _bench / "bench_bias_lighting.py")
bbl = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bbl)


def _T(rotvec_deg, t_mm):
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.radians(rotvec_deg)).as_matrix()
    T[:3, 3] = t_mm
    return T


def test_world_fixed_lights_keep_their_world_direction():
    spec = [{"type": "SUN", "direction_cam": [0.25, 1.0, 0.6], "strength": 3.5},
            {"type": "SUN", "direction_cam": [-0.9, 0.5, 0.2], "strength": 2.0}]
    T0 = _T([100.0, 10.0, -5.0], [10.0, -20.0, 900.0])
    T1 = _T([95.0, 40.0, 20.0], [-300.0, 15.0, 1000.0])        # the camera turned by ~30 deg, moved
    at0 = bbl.world_fixed_lights(spec, T0, T0)
    at1 = bbl.world_fixed_lights(spec, T0, T1)
    for s, a0, a1 in zip(spec, at0, at1):
        assert np.allclose(a0["direction_cam"], s["direction_cam"], atol=1e-12)    # frame 0: the spec itself
        d_world0 = T0[:3, :3].T @ np.asarray(a0["direction_cam"])
        d_world1 = T1[:3, :3].T @ np.asarray(a1["direction_cam"])
        assert np.allclose(d_world0, d_world1, atol=1e-12)
        # and it is not the camera-fixed light: the direction in the camera moved with the turn
        turn_deg = np.degrees(np.arccos(np.dot(a0["direction_cam"], a1["direction_cam"])
                                        / np.linalg.norm(a0["direction_cam"]) / np.linalg.norm(a1["direction_cam"])))
        assert turn_deg > 5.0
        assert a1["strength"] == s["strength"] and a1["type"] == "SUN"
