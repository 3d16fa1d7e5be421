"""refine.table_contact: the touching objects held to one plane of the table's measured normal
(RefineOptions.table_contact; the normal table_rotation measures is tested in test_table.py)."""
import numpy as np
import trimesh

from ycbvss.geometry.so3 import exp_so3
from ycbvss.refine.problem import BundleProblem, View
from ycbvss.refine.table_contact import TableContactTerm, lowest_point, mean_normal, normal_sigma_deg


def _boxes_on_a_table(turn_deg=0.0):
    """Three boxes standing on the plane z = 0 (world = camera 0 at 1 m looking down at 50 deg),
    the whole set turned by ``turn_deg`` about the world y axis through (0, 0, 1000)."""
    cam = np.eye(4)
    exts = [(60.0, 40, 100), (80, 80, 30), (50, 50, 50)]
    places = [(-200.0, 0), (150, 60), (20, -150)]
    # table frame: origin 1 m in front of camera 0, its z axis (up) tilted toward the camera
    R_t = exp_so3(np.radians([-140.0, 0, 0]))
    T_t = np.eye(4)
    T_t[:3, :3], T_t[:3, 3] = R_t, (0.0, 0.0, 1000.0)
    turn = np.eye(4)
    turn[:3, :3] = exp_so3(np.radians([0.0, turn_deg, 0.0]))
    pivot = np.eye(4)
    pivot[:3, 3] = (0.0, 0.0, 1000.0)
    turn = pivot @ turn @ np.linalg.inv(pivot)
    hulls, T_m = [], []
    for e, (x, y) in zip(exts, places):
        b = trimesh.creation.box(e)
        T = np.eye(4)
        T[:3, 3] = (x, y, e[2] / 2)
        T_m.append(turn @ T_t @ T)
        hulls.append(np.asarray(b.vertices))
    n_w = R_t @ [0, 0, 1.0]
    return cam, np.stack(T_m), hulls, n_w


def _problem(T_m):
    K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
    return BundleProblem([View(0, K, 640, 480)], [1, 2, 3], np.eye(4)[None], T_m,
                         cam_free=np.array([False]), obj_free=np.ones(3, bool))


def test_lowest_point_and_mean_normal():
    _, T_m, hulls, n = _boxes_on_a_table()
    for T, X in zip(T_m, hulls):
        h, W = lowest_point(T, X, n)
        assert abs(h - float(n @ T_m[0][:3, 3] - 50.0)) < 1e-9       # every box's bottom on the table plane
        assert abs(W @ n - h) < 1e-12
    # sign follows `up`; the better measurement (smaller covariance) weighs more
    a, b = exp_so3(np.radians([0.2, 0, 0])) @ n, exp_so3(np.radians([-0.2, 0, 0])) @ n
    m = mean_normal([a, -b], [np.eye(3) * 1e-6, np.eye(3) * 3e-6], n)
    assert m @ n > 0 and abs(np.linalg.norm(m) - 1) < 1e-12
    assert np.degrees(np.arccos(min(m @ a, 1.0))) < np.degrees(np.arccos(min(m @ b, 1.0)))
    assert mean_normal([np.full(3, np.nan)], [np.eye(3)], n) is None


def test_gradient_matches_finite_differences_and_common_height_is_free(fd_gradient):
    from ycbvss.refine.solver import assemble
    _, T_m, hulls, n = _boxes_on_a_table(turn_deg=0.3)
    pb = _problem(T_m)
    term = TableContactTerm(n, [(j, X) for j, X in enumerate(hulls)], sigma_mm=0.5)
    c0, lins = term.linearize(pb)
    assert c0 > 0 and np.isclose(c0, term.cost(pb))
    _, g = assemble(pb.n_blocks, lins)
    num = fd_gradient(pb, term, 1e-6)
    assert np.allclose(g, num, rtol=1e-3, atol=1e-4 * np.abs(num).max())
    # lifting every object together along the normal (the table's distance: the scene's scale) costs nothing
    pb.apply_step(np.tile(np.r_[5.0 * n, 0, 0, 0], 3))
    assert abs(term.cost(pb) - c0) < 1e-9 * c0


def test_solve_levels_a_jointly_turned_set_and_leaves_a_level_one():
    from ycbvss.refine.solver import SolverOptions, run_lm
    _, T_m, hulls, n = _boxes_on_a_table(turn_deg=0.2)
    pb = _problem(T_m)
    term = TableContactTerm(n, [(j, X) for j, X in enumerate(hulls)], sigma_mm=0.5)
    h0 = np.array([lowest_point(T, X, n)[0] for T, X in zip(pb.T_m, hulls)])
    assert np.ptp(h0) > 0.5                                   # 0.2 deg over ~350 mm: the boxes' heights differ
    run_lm(pb, [term], SolverOptions(max_iters=30))
    h1 = np.array([lowest_point(T, X, n)[0] for T, X in zip(pb.T_m, hulls)])
    assert np.ptp(h1) < 0.01 * np.ptp(h0)
    # level already: no cost, no move
    _, T_level, _, _ = _boxes_on_a_table()
    pb2 = _problem(T_level)
    assert term.cost(pb2) < 1e-18
    run_lm(pb2, [term], SolverOptions(max_iters=5))
    assert np.max(np.abs(pb2.T_m - T_level)) < 1e-9


def test_a_non_finite_pose_is_left_out_and_does_not_reach_the_others():
    from ycbvss.refine.solver import assemble
    _, T_m, hulls, n = _boxes_on_a_table(turn_deg=0.3)
    T_m[1][:3, 3] = np.nan
    pb = _problem(T_m)
    term = TableContactTerm(n, [(j, X) for j, X in enumerate(hulls)], sigma_mm=0.5)
    c, lins = term.linearize(pb)
    assert np.isfinite(c) and c > 0 and np.isclose(c, term.cost(pb))
    assert len(lins) == 1 and {lins[0].a, lins[0].b} == {int(pb.obj_block[0]), int(pb.obj_block[2])}
    H, g = assemble(pb.n_blocks, lins)
    assert np.all(np.isfinite(H)) and np.all(np.isfinite(g))


def test_normal_sigma_combines_the_measurements_and_ignores_unusable_ones():
    one = np.diag([np.radians(0.1) ** 2, np.radians(0.1) ** 2, 0.0])     # 0.14 deg in the plane's tangent
    assert abs(normal_sigma_deg([one]) - np.sqrt(2) * 0.1) < 1e-9
    # four equal measurements: half the sigma of one
    assert abs(normal_sigma_deg([one] * 4) - normal_sigma_deg([one]) / 2) < 1e-9
    assert normal_sigma_deg([one, np.full((3, 3), np.nan), np.zeros((3, 3))]) == normal_sigma_deg([one])
    assert normal_sigma_deg([]) == float("inf")
