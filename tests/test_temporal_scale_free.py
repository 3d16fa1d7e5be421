"""f_t's per-pair scale nuisance (refine.terms.TemporalTerm.scale_free).

Two cameras 300 mm apart look at points 1.2-1.6 m away. The matches in view 1 are the exact transfer
of camera 0's points, then every displacement from the source pixel is shortened by 0.5 % (a flow
that reads the parallax short). Camera 1 is refined by f_t alone from the exact pose. The plain term
moves the camera to fit the short parallax, shortening the baseline; with the scale nuisance the
shortfall goes into the pair's scale, and the baseline's length stays. Nothing here is rendered.
"""
import numpy as np

from ycbvss.geometry.se3 import inv_T
from ycbvss.refine.jacobians import project_points
from ycbvss.refine.problem import BundleProblem, View
from ycbvss.refine.solver import SolverOptions, run_lm
from ycbvss.refine.terms import TemporalGroup, TemporalTerm

K = np.array([[1066.8, 0.0, 320.0], [0.0, 1067.5, 240.0], [0.0, 0.0, 1.0]])


def _pose(yaw_deg: float, t_mm) -> np.ndarray:
    a = np.deg2rad(yaw_deg)
    T = np.eye(4)
    T[:3, :3] = [[np.cos(a), 0.0, np.sin(a)], [0.0, 1.0, 0.0], [-np.sin(a), 0.0, np.cos(a)]]
    T[:3, 3] = t_mm
    return T


def _refine(scale_free: bool, shrink: float) -> tuple[float, float, TemporalTerm, BundleProblem]:
    rng = np.random.default_rng(3)
    T0, T1 = np.eye(4), _pose(-8.0, [-300.0, 5.0, 20.0])      # world-to-camera
    Y0 = np.column_stack([rng.uniform(-150, 150, 400), rng.uniform(-120, 120, 400), rng.uniform(1200, 1600, 400)])
    xs = project_points(K, np.eye(4), Y0)[0]
    x1 = project_points(K, T1 @ inv_T(T0), Y0)[0]
    xd = xs + (1.0 - shrink) * (x1 - xs)
    views = [View(0, K, 640, 480), View(1, K, 640, 480)]
    pb = BundleProblem(views, [], np.stack([T0, T1]), np.zeros((0, 4, 4)))
    term = TemporalTerm([TemporalGroup(1, 0, Y0, xd)], weight=1.0, rho=2.0, floor_px=0.0, scale_free=scale_free)
    run_lm(pb, [term], SolverOptions(max_iters=30))
    c1 = -pb.T_c[1][:3, :3].T @ pb.T_c[1][:3, 3]              # camera 1's centre in the world (mm)
    c1_true = -T1[:3, :3].T @ T1[:3, 3]
    return float(np.linalg.norm(c1)), float(np.linalg.norm(c1_true)), term, pb


def test_plain_pair_shortens_the_baseline():
    b, b_true, _, _ = _refine(False, 0.005)
    assert (b_true - b) / b_true > 0.002, (b, b_true)          # measured 0.6 %


def test_scale_free_pair_keeps_the_baseline():
    b, b_true, term, pb = _refine(True, 0.005)
    assert abs(b - b_true) / b_true < 2e-4, (b, b_true)
    s = term._best_scale(pb, term.groups[0])
    assert 0.0 < s < 0.02, s          # a parallax read short at the same baseline: the points lie farther


def test_scale_free_pair_still_fixes_the_rotation():
    """An exact pair started 0.3 deg off in yaw comes back: the nuisance takes only the depth scale."""
    rng = np.random.default_rng(4)
    T0, T1 = np.eye(4), _pose(-8.0, [-300.0, 5.0, 20.0])
    Y0 = np.column_stack([rng.uniform(-150, 150, 300), rng.uniform(-120, 120, 300), rng.uniform(1200, 1600, 300)])
    xs = project_points(K, np.eye(4), Y0)[0]
    xd = project_points(K, T1, Y0)[0]
    pb = BundleProblem([View(0, K, 640, 480), View(1, K, 640, 480)], [], np.stack([T0, _pose(-8.3, T1[:3, 3])]),
                       np.zeros((0, 4, 4)))
    term = TemporalTerm([TemporalGroup(1, 0, Y0, xd)], weight=1.0, rho=2.0, floor_px=0.0, scale_free=True)
    run_lm(pb, [term], SolverOptions(max_iters=30))
    R = pb.T_c[1][:3, :3] @ T1[:3, :3].T
    assert np.rad2deg(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))) < 0.01
    assert len(xs) == 300
