"""refine.table: the support plane, plane depths and table corner matches (RefineOptions.table_flow)."""
import cv2
import numpy as np
import trimesh

from ycbvss.refine.jacobians import backproject_px
from ycbvss.refine.table import plane_depth_mm, support_plane, table_matches


def _box_points(extent, centre, yaw_deg=0.0):
    b = trimesh.creation.box(extent)
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    R = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    return b.vertices @ R.T + np.asarray(centre, float)


def _look_at(eye, target):
    """World-to-camera 4x4 (OpenCV axes: z forward, y down) of a camera at ``eye`` looking at ``target``."""
    z = np.asarray(target, float) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0, 0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, -R @ eye
    return T


def test_support_plane_finds_the_table_under_resting_and_stacked_boxes():
    tilt = trimesh.transformations.rotation_matrix(np.radians(12.0), [1, 0.3, 0])
    objs = [_box_points((60, 40, 100), (0, 0, 50), 10), _box_points((80, 80, 30), (150, 20, 15), 40),
            _box_points((50, 50, 50), (-40, 160, 25), 75),
            _box_points((40, 40, 40), (0, 0, 120), 20)]            # stacked on the first: not touching
    objs = [p @ tilt[:3, :3].T + (5.0, -7.0, 300.0) for p in objs]
    n_true = tilt[:3, :3] @ [0, 0, 1.0]
    d_true = float(n_true @ (5.0, -7.0, 300.0))
    cams = np.array([[0, -800, 900], [300, -700, 800], [-300, -750, 850.0]]) @ tilt[:3, :3].T + (5.0, -7.0, 300.0)
    n, d, touching = support_plane(objs, cams)
    assert touching == 3
    assert np.degrees(np.arccos(np.clip(n @ n_true, -1, 1))) < 1e-6 and abs(d - d_true) < 1e-6
    # seen from below, no face has every camera above it but the top ones: the answer is not the table
    below = support_plane(objs, -cams + 2 * np.array([5.0, -7.0, 300.0]))
    assert below is None or below[0] @ n_true < 0.5


def test_plane_depth_matches_the_ray_plane_intersection():
    K = np.array([[600.0, 0, 320], [0, 610.0, 240], [0, 0, 1]])
    T = _look_at(np.array([100.0, -600, 700]), np.array([0.0, 0, 0]))
    uv = np.array([[320.0, 240.0], [10.0, 470.0], [600.0, 30.0]])
    z = plane_depth_mm(K, T, np.array([0, 0, 1.0]), 0.0, uv)
    X_c = backproject_px(K, uv, z)
    X_w = (X_c - T[:3, 3]) @ T[:3, :3]          # R^T (X_c - t)
    assert np.all(z > 0) and np.max(np.abs(X_w[:, 2])) < 1e-9
    # the horizon and above: no intersection in front of the camera
    up = plane_depth_mm(K, _look_at(np.array([0.0, -600, 100]), np.array([0.0, 0, 100])), np.array([0, 0, 1.0]), 0.0,
                        np.array([[320.0, 0.0]]))
    assert up[0] == 0.0


def test_table_matches_follow_the_plane_homography_and_skip_the_objects():
    rng = np.random.default_rng(3)
    tex = cv2.GaussianBlur((rng.random((480, 640)) * 255).astype(np.uint8), (0, 0), 2.0)
    tex = cv2.normalize(tex, None, 0, 255, cv2.NORM_MINMAX)
    H = np.array([[1.01, 0.02, 3.5], [-0.015, 0.995, -2.25], [1.2e-5, -0.8e-5, 1.0]])
    warped = cv2.warpPerspective(tex, H, (640, 480), flags=cv2.INTER_CUBIC)
    obj = np.zeros((480, 640), bool)
    obj[180:300, 260:380] = True
    xa, xb = table_matches(np.dstack([tex] * 3), np.dstack([warped] * 3), obj, None, n_points=600)
    assert len(xa) > 300
    p = np.c_[xa, np.ones(len(xa))] @ H.T
    err = np.linalg.norm(p[:, :2] / p[:, 2:] - xb, axis=1)
    assert np.median(err) < 0.05 and np.percentile(err, 95) < 0.2
    # no corner within 10 px of the object
    near = (xa[:, 0] > 250) & (xa[:, 0] < 390) & (xa[:, 1] > 170) & (xa[:, 1] < 310)
    assert not near.any()


def _two_views_of_a_plane(rng, noise_px=0.05, half_baseline_mm=60.0):
    K = np.array([[1066.8, 0, 312.99], [0, 1067.5, 241.31], [0, 0, 1.0]])
    T_w = [_look_at(np.array([x, -700.0, 650.0]), np.array([0.0, 0, 0])) for x in (-half_baseline_mm, half_baseline_mm)]
    xs = np.c_[rng.uniform(20, 620, 500), rng.uniform(20, 460, 500)]
    z = plane_depth_mm(K, T_w[0], np.array([0, 0, 1.0]), 0.0, xs)
    xs, z = xs[z > 0], z[z > 0]
    T = T_w[1] @ np.linalg.inv(T_w[0])
    Xi = backproject_px(K, xs, z) @ T[:3, :3].T + T[:3, 3]
    xd = (Xi / Xi[:, 2:]) @ K.T
    xd = xd[:, :2] + rng.normal(0, noise_px, (len(xs), 2))
    xd[:30] += rng.normal(0, 20, (30, 2))                              # outliers
    return K, T_w, T, xs, xd


def test_table_rotation_measures_the_relative_rotation_with_an_honest_covariance():
    from ycbvss.geometry.so3 import exp_so3, log_so3
    from ycbvss.refine.table import table_rotation
    errs, zs = [], []
    for seed in range(8):
        rng = np.random.default_rng(seed)
        K, T_w, T, xs, xd = _two_views_of_a_plane(rng)
        guess = exp_so3(np.radians([0.5, -0.3, 0.4])) @ T[:3, :3]     # the current estimate, off by ~0.7 deg
        R, cov, n_inl, med = table_rotation(xs, xd, K, K, guess, T_w[0][:3, :3] @ [0, 0, 1.0])
        e = log_so3(R @ T[:3, :3].T)
        errs.append(np.degrees(np.linalg.norm(e)))
        zs.append(e @ np.linalg.solve(cov, e))                        # chi-square, 3 dof
        assert n_inl >= 0.95 * (len(xs) - 30) and med < 0.1          # the 30 outliers out, nearly all others in
    assert max(errs) < 0.01                                           # 0.05 px matches: rotation within 0.01 deg
    assert 0.5 < np.mean(zs) < 8.0                                    # mean chi2(3) = 3: the covariance is not off by 3x


def test_table_rotation_measures_the_plane_normal():
    from ycbvss.refine.table import table_rotation
    errs = []
    for seed in range(6):
        K, T_w, T, xs, xd = _two_views_of_a_plane(np.random.default_rng(seed), half_baseline_mm=150.0)
        n_true = T_w[0][:3, :3] @ [0, 0, 1.0]
        out = table_rotation(xs, xd, K, K, T[:3, :3], n_true, with_normal=True)
        assert len(out) == 6
        nn, cov_n = out[4], out[5]
        if nn @ n_true < 0:
            nn = -nn
        errs.append(np.degrees(np.arccos(min(float(nn @ n_true), 1.0))))
        assert abs(float(cov_n @ n_true @ n_true)) < 1e-3 * np.trace(cov_n)   # in the tangent only
    assert max(errs) < 0.05                                   # 0.05 px matches, ~25 deg apart: measured <= 0.016 deg


def test_table_rotation_of_a_camera_that_only_turned_is_none_without_noise(capfd):
    """A pure rotation (no translation, e.g. a tripod pan or the shared clips' nearly still camera): OpenCV's
    decomposition gives a zero normal. Before: NaN residuals, a RuntimeWarning ("invalid value encountered
    in divide", printed by CI in test_refine_synthetic.py's blur-schedule test) and LAPACK's "DLASCL
    parameter number 4 had an illegal value" on stderr, then None."""
    import warnings

    from ycbvss.geometry.so3 import exp_so3
    from ycbvss.refine.table import table_rotation
    K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
    xs = np.random.default_rng(0).uniform([50, 50], [590, 430], (300, 2))
    R = exp_so3(np.radians([1.0, 2.0, 0.5]))
    y = np.c_[xs, np.ones(len(xs))] @ (K @ R @ np.linalg.inv(K)).T
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert table_rotation(xs, y[:, :2] / y[:, 2:], K, K, R, with_normal=True) is None
    out, err = capfd.readouterr()
    assert "DLASCL" not in out + err


def test_table_rotation_term_gradient_and_solve(fd_gradient):
    from ycbvss.geometry.se3 import exp_se3
    from ycbvss.geometry.so3 import exp_so3, log_so3
    from ycbvss.refine.problem import BundleProblem, View
    from ycbvss.refine.solver import SolverOptions, assemble, run_lm
    from ycbvss.refine.table import TableRotation, TableRotationTerm, whitening
    K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]])
    views = [View(i, K, 640, 480) for i in range(3)]
    T_c = np.stack([np.eye(4), exp_se3(np.r_[50.0, 0, 0, 0, np.radians(3), 0]),
                    exp_se3(np.r_[100.0, 5, 0, np.radians(1), np.radians(6), 0])])
    R_meas = [exp_so3(np.radians([0.2, 0.1, -0.1])) @ T_c[1][:3, :3],
              exp_so3(np.radians([-0.1, 0.3, 0.05])) @ T_c[2][:3, :3] @ T_c[1][:3, :3].T]
    cov = np.diag([1e-8, 4e-8, 2e-8]) + 5e-9
    pairs = [TableRotation(1, 0, R_meas[0], whitening(cov)), TableRotation(2, 1, R_meas[1], whitening(cov))]
    pb = BundleProblem(views, [], T_c, np.zeros((0, 4, 4)), cam_free=np.array([False, True, True]), obj_free=np.zeros(0, bool))
    term = TableRotationTerm(pairs, weight=1.0)
    c0, lins = term.linearize(pb)
    assert c0 > 0 and np.isclose(c0, term.cost(pb))
    _, g = assemble(pb.n_blocks, lins)
    num = fd_gradient(pb, term, 1e-7)
    assert np.allclose(g, num, rtol=1e-3, atol=1e-4 * np.abs(num).max())
    run_lm(pb, [term], SolverOptions(max_iters=20))
    for p, R in zip(pairs, R_meas):
        R_now = pb.T_c[p.i][:3, :3] @ pb.T_c[p.k][:3, :3].T
        assert np.degrees(np.linalg.norm(log_so3(R_now @ R.T))) < 1e-4
    assert term.cost(pb) < 1e-8 * c0


def _plane_texture(seed=3, shape=(480, 640), sigma=2.0):
    rng = np.random.default_rng(seed)
    tex = cv2.GaussianBlur((rng.random(shape) * 255).astype(np.uint8), (0, 0), sigma)
    return cv2.normalize(tex, None, 0, 255, cv2.NORM_MINMAX)


def test_predicted_homography_carries_plane_points_between_views():
    from ycbvss.refine.table import predicted_homography
    K = np.array([[1066.8, 0, 312.99], [0, 1067.5, 241.31], [0, 0, 1.0]])
    n_w, d_w = np.array([0.1, -0.05, 1.0]) / np.linalg.norm([0.1, -0.05, 1.0]), 12.0
    Ta = _look_at(np.array([-150.0, -700.0, 650.0]), np.array([0.0, 0, 0]))
    Tb = _look_at(np.array([200.0, -650.0, 700.0]), np.array([20.0, 10, 0]))
    uv = np.c_[np.random.default_rng(0).uniform(0, 640, 50), np.random.default_rng(1).uniform(0, 480, 50)]
    z = plane_depth_mm(K, Ta, n_w, d_w, uv)
    X_w = (backproject_px(K, uv, z) - Ta[:3, 3]) @ Ta[:3, :3]
    X_b = X_w @ Tb[:3, :3].T + Tb[:3, 3]
    uv_b = (X_b / X_b[:, 2:]) @ K.T
    H = predicted_homography(K, K, Ta, Tb, n_w, d_w)
    y = np.c_[uv, np.ones(len(uv))] @ H.T
    assert np.max(np.abs(y[:, :2] / y[:, 2:] - uv_b[:, :2])) < 1e-8


def test_guided_matches_hold_over_a_wide_turn_where_unguided_ones_thin_out():
    """Two views of a textured plane 20 deg apart (image b made by OpenCV's warp of a with the
    plane's exact homography): guided by a prediction 0.3 deg and 10 mm off, the matches follow the
    true homography to a few hundredths of a pixel; unguided Lucas-Kanade keeps far fewer."""
    from ycbvss.geometry.so3 import exp_so3
    from ycbvss.refine.table import predicted_homography
    K = np.array([[1066.8, 0, 312.99], [0, 1067.5, 241.31], [0, 0, 1.0]])
    n_w = np.array([0, 0, 1.0])
    target = np.array([0.0, 0, 0])
    eye_a = np.array([0.0, -650.0, 700.0])
    c, s = np.cos(np.radians(20.0)), np.sin(np.radians(20.0))
    eye_b = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]]) @ eye_a          # 20 deg about the table's normal
    Ta, Tb = _look_at(eye_a, target), _look_at(eye_b, target)
    H_true = predicted_homography(K, K, Ta, Tb, n_w, 0.0)
    tex = _plane_texture()
    img_b = cv2.warpPerspective(tex, H_true, (640, 480), flags=cv2.INTER_CUBIC)
    obj = np.zeros((480, 640), bool)
    obj[200:280, 280:360] = True
    Tb_est = Tb.copy()
    Tb_est[:3, :3] = exp_so3(np.radians([0.2, -0.15, 0.15])) @ Tb[:3, :3]
    Tb_est[:3, 3] += (6.0, -5.0, 6.0)
    H_pred = predicted_homography(K, K, Ta, Tb_est, n_w, 0.0)
    xa, xb = table_matches(tex, img_b, obj, None, n_points=800, H_pred=H_pred)
    p = np.c_[xa, np.ones(len(xa))] @ H_true.T
    err = np.linalg.norm(p[:, :2] / p[:, 2:] - xb, axis=1)
    assert len(xa) > 300
    assert np.median(err) < 0.05 and np.percentile(err, 95) < 0.2
    xa_u, _ = table_matches(tex, img_b, obj, None, n_points=800)
    assert len(xa_u) < 0.5 * len(xa)


def test_span_pairs_take_the_earliest_view_within_the_turn():
    from ycbvss.geometry.so3 import exp_so3
    from ycbvss.refine.table import span_pairs
    R = np.stack([exp_so3(np.radians([0.0, 2.5 * i, 0.0])) for i in range(9)])      # 0, 2.5, ..., 20 deg
    temporal = [(i, i + 1) for i in range(8)] + [(i + 1, i) for i in range(8)]
    assert span_pairs(R, temporal, 30.0) == [(0, i) for i in range(2, 9)]
    pairs = span_pairs(R, temporal, 10.0)
    assert pairs == [(0, 2), (0, 3), (0, 4), (1, 5), (2, 6), (3, 7), (4, 8)]
    assert span_pairs(R, temporal + [(0, 2)], 30.0)[0] == (0, 3)
