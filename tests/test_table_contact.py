"""refine.table_contact: the touching objects held to one plane of the table's measured normal
(RefineOptions.table_contact), and the plane normal table_rotation measures."""
import numpy as np
import trimesh

from ycbvss.geometry.se3 import exp_se3
from ycbvss.geometry.so3 import exp_so3
from ycbvss.refine.problem import BundleProblem, View
from ycbvss.refine.table_contact import TableContactTerm, lowest_point, mean_normal


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


def test_table_rotation_measures_the_plane_normal():
    import cv2  # noqa: F401  (OpenCV's homography under test)
    from ycbvss.refine.jacobians import backproject_px
    from ycbvss.refine.table import plane_depth_mm, table_rotation
    K = np.array([[1066.8, 0, 312.99], [0, 1067.5, 241.31], [0, 0, 1.0]])
    errs = []
    for seed in range(6):
        rng = np.random.default_rng(seed)
        T_w = []
        for x in (-150.0, 150.0):
            eye = np.array([x, -700.0, 650.0])
            z = -eye / np.linalg.norm(eye)
            xa = np.cross(z, [0, 0, 1.0])
            xa /= np.linalg.norm(xa)
            R = np.stack([xa, np.cross(z, xa), z])
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = R, -R @ eye
            T_w.append(T)
        xs = np.c_[rng.uniform(20, 620, 500), rng.uniform(20, 460, 500)]
        zz = plane_depth_mm(K, T_w[0], np.array([0, 0, 1.0]), 0.0, xs)
        xs, zz = xs[zz > 0], zz[zz > 0]
        T = T_w[1] @ np.linalg.inv(T_w[0])
        Xi = backproject_px(K, xs, zz) @ T[:3, :3].T + T[:3, 3]
        xd = (Xi / Xi[:, 2:]) @ K.T
        xd = xd[:, :2] + rng.normal(0, 0.05, (len(xs), 2))
        n_true = T_w[0][:3, :3] @ [0, 0, 1.0]
        out = table_rotation(xs, xd, K, K, T[:3, :3], n_true, with_normal=True)
        assert len(out) == 6
        nn, cov_n = out[4], out[5]
        if nn @ n_true < 0:
            nn = -nn
        errs.append(np.degrees(np.arccos(min(float(nn @ n_true), 1.0))))
        assert abs(float(cov_n @ n_true @ n_true)) < 1e-3 * np.trace(cov_n)   # in the tangent only
    assert max(errs) < 0.05                                   # 0.05 px matches, ~25 deg apart: measured <= 0.013 deg


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
