"""Pose-error metrics: hand-computed cases, invariants, exactness of the ADD-S index, symmetries.
Budget: < 10 s (numba kernels load from the on-disk cache; ~10 s more on a first compile)."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from ycbvss.eval.metrics import add_mm, adds_mm, pose_errors, prj_px, re_deg, te_axes_mm, te_mm
from ycbvss.eval.model_points import ModelPoints
from ycbvss.eval.reference import errors_loop
from ycbvss.geometry.symmetry import closest_symmetric_gt, continuous_steps, symmetry_group
from ycbvss.geometry.so3 import exp_so3

K = np.array([[1066.778, 0.0, 312.9869], [0.0, 1067.487, 241.3109], [0.0, 0.0, 1.0]])


def _cloud(rng, n=2000, axes=(40.0, 60.0, 90.0)):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True) * np.asarray(axes)


def _random_pairs(rng, n, t_sigma, r_sigma_deg):
    Rg = exp_so3(rng.normal(size=(n, 3)) * 2.0)
    tg = rng.uniform([-150, -150, 500], [150, 150, 1300], (n, 3))
    Re = exp_so3(rng.normal(size=(n, 3)) * np.radians(r_sigma_deg)) @ Rg
    te = tg + rng.normal(size=(n, 3)) * t_sigma
    return Re, te, Rg, tg


def test_translation_only_hand_computed():
    pts = np.array([[10.0, 0, 0], [0, 20, 0], [0, 0, 30], [-5, -5, 5]])
    R = np.eye(3)
    tg, te = np.array([0.0, 0, 800]), np.array([3.0, -4.0, 0.0]) + [0, 0, 800]
    assert np.allclose(te_axes_mm(te, tg), [3, 4, 0], atol=1e-12)
    assert abs(te_mm(te, tg) - 5.0) < 1e-12
    assert abs(re_deg(R, R)) < 1e-9
    assert abs(add_mm(R, te, R, tg, pts) - 5.0) < 1e-12        # every point moves by 5 mm
    assert adds_mm(R, te, R, tg, pts) <= 5.0 + 1e-12


def test_rotation_square_hand_computed():
    # a square turned by 90 deg about z: each corner lands on the next one
    pts = np.array([[10.0, 0, 0], [0, 10, 0], [-10, 0, 0], [0, -10, 0]])
    Rg, t = np.eye(3), np.array([0.0, 0, 500])
    Re = exp_so3(np.array([0, 0, np.pi / 2]))
    assert abs(re_deg(Re, Rg) - 90.0) < 1e-9
    assert abs(add_mm(Re, t, Rg, t, pts) - 10.0 * np.sqrt(2)) < 1e-9
    assert abs(adds_mm(Re, t, Rg, t, pts)) < 1e-9


def test_prj_lateral_shift_hand_computed():
    # planar model at depth Z: a lateral shift dx projects to fx * dx / Z pixels for every point
    pts = np.array([[10.0, 5, 0], [-20, 3, 0], [7, -9, 0]])
    R, Z, dx = np.eye(3), 1000.0, 5.0
    e = prj_px(R, np.array([dx, 0, Z]), R, np.array([0.0, 0, Z]), K, pts)
    assert abs(e - K[0, 0] * dx / Z) < 1e-9


def test_identical_poses_zero_and_adds_le_add():
    rng = np.random.default_rng(1)
    pts = _cloud(rng, 1500)
    Re, te, Rg, tg = _random_pairs(rng, 64, 8.0, 3.0)
    z = pose_errors(Rg, tg, Rg, tg, K, pts)
    for k, v in z.items():
        assert np.max(np.abs(v)) < 1e-9, k
    e = pose_errors(Re, te, Rg, tg, K, pts)
    assert np.all(e["adds_mm"] <= e["add_mm"] + 1e-9)
    assert np.all(e["add_mm"] > 0)


@pytest.mark.parametrize("t_sigma,r_deg", [(0.3, 0.1), (2.0, 1.0), (40.0, 20.0)])
def test_model_points_exact_against_brute_force(t_sigma, r_deg):
    """Fast path (small errors) and KD-tree fallback (large errors) equal a brute-force search."""
    rng = np.random.default_rng(2)
    pts = _cloud(rng, 800)
    Re, te, Rg, tg = _random_pairs(rng, 40, t_sigma, r_deg)
    mp = ModelPoints(pts, k=8, backend="scipy")          # the pure-scipy path (numba: see below)
    got = adds_mm(Re, te, Rg, tg, mp)
    from scipy.spatial.distance import cdist
    d = np.array([cdist(pts @ Rg[i].T + tg[i], pts @ Re[i].T + te[i]).min(axis=1).mean()
                  for i in range(len(Re))])
    assert np.max(np.abs(got - d)) < 1e-9
    if t_sigma < 1.0:       # small errors: (almost) all points certified by the candidate lists
        assert mp.stats["certified"] >= 0.95 * (mp.stats["certified"] + mp.stats["tree"])


def test_vectorised_equals_per_pose_reference():
    rng = np.random.default_rng(3)
    pts = _cloud(rng, 1200)
    Re, te, Rg, tg = _random_pairs(rng, 60, 5.0, 2.0)
    fast = pose_errors(Re, te, Rg, tg, K, ModelPoints(pts), poses_per_block=7)   # several blocks
    ref = errors_loop(Re, te, Rg, tg, K, pts)
    for k in ref:
        assert np.max(np.abs(fast[k] - ref[k])) < 1e-6, k


def _bowl_points(n_ang=360, n_prof=12):
    """A surface of revolution about z (a bowl), sampled every 1 degree."""
    a = np.radians(np.arange(n_ang) * 360.0 / n_ang)
    prof_r = np.linspace(20.0, 80.0, n_prof)
    prof_z = 0.01 * prof_r ** 2
    r, ang = np.meshgrid(prof_r, a)
    z = np.broadcast_to(prof_z, r.shape)
    return np.stack([r * np.cos(ang), r * np.sin(ang), z], axis=-1).reshape(-1, 3)


def test_bowl_rotated_about_axis_adds_near_zero():
    pts = _bowl_points()
    Rg, tg = exp_so3(np.array([0.3, -0.2, 0.1])), np.array([20.0, -10, 700])
    for ang_deg in (37.0, 37.5):
        Re = Rg @ exp_so3(np.array([0, 0, np.radians(ang_deg)]))   # rotation about the model axis
        add, adds = add_mm(Re, tg, Rg, tg, pts), adds_mm(Re, tg, Rg, tg, pts)
        # off-grid angle: a point is at most r_max * sin(0.5 deg / 2 ... ) from a sample
        assert adds <= 80.0 * np.radians(0.5) + 1e-9
        assert add > 20.0                                # ADD sees the 37 deg rotation
    assert adds_mm(Rg @ exp_so3(np.array([0, 0, np.radians(37.0)])), tg, Rg, tg, pts) < 1e-9


def test_symmetry_transforms_and_closest_gt():
    rng = np.random.default_rng(4)
    pts = _cloud(rng, 500, axes=(30.0, 50.0, 70.0))
    # discrete 180 deg about z
    S = np.eye(4)
    S[:3, :3] = exp_so3(np.array([0, 0, np.pi]))
    syms = symmetry_group([S.reshape(-1).tolist()], None, continuous_steps(0.01))
    assert syms.shape == (2, 4, 4)
    Rg, tg = exp_so3(np.array([0.5, 0.1, -0.3])), np.array([0.0, 0, 600])
    Re = Rg @ S[:3, :3]                                   # the estimate is the symmetric twin
    Rn, tn, idx = closest_symmetric_gt(Re[None], tg[None], Rg[None], tg[None], syms, pts)
    assert idx[0] == 1 and re_deg(Re, Rn[0]) < 1e-6 and np.abs(tn[0] - tg).max() < 1e-9
    # continuous symmetry about z through an offset: sampled every 360/315 deg
    cs = symmetry_group(None, [{"axis": [0, 0, 1], "offset": [5.0, 0, 0]}], continuous_steps(0.01))
    assert len(cs) == 315
    Rz = exp_so3(np.array([0, 0, np.radians(33.0)]))
    off = np.array([5.0, 0, 0])
    Re2 = Rg @ Rz
    te2 = tg + Rg @ (off - Rz @ off)
    Rn, tn, _ = closest_symmetric_gt(Re2[None], te2[None], Rg[None], tg[None], cs, pts)
    assert re_deg(Re2, Rn[0]) <= 360.0 / 315 / 2 + 1e-6


def _brute_adds(pts, A, b):
    from scipy.spatial.distance import cdist
    return np.array([cdist(pts @ A[j].T + b[j], pts).min(axis=1).mean() for j in range(len(A))])


@pytest.mark.parametrize("n_pts", [1, 5, 9, 700])
def test_numba_kernel_exact_against_brute_force(n_pts):
    """Compiled KD-tree kernel (certified candidates + tree) equals brute force for refined,
    tracker-level and gross errors, tiny models (fewer points than candidates) and duplicates."""
    from ycbvss.eval.metrics import relative_model_transform
    rng = np.random.default_rng(5)
    pts = _cloud(rng, n_pts)
    if n_pts > 5:
        pts[-3:] = pts[:3]                                   # duplicated vertices
    mp = ModelPoints(pts, backend="numba")
    assert mp.backend == "numba"
    worst = 0.0
    for t_sigma, r_deg in ((0.3, 0.1), (10.0, 3.0), (80.0, 40.0)):
        A, b = relative_model_transform(*_random_pairs(rng, 30, t_sigma, r_deg))
        add, adds = mp.add_adds(A, b)
        worst = max(worst, np.max(np.abs(adds - _brute_adds(pts, A, b))))
        add_ref = np.array([np.linalg.norm(pts @ A[j].T + b[j] - pts, axis=1).mean() for j in range(len(A))])
        worst = max(worst, np.max(np.abs(add - add_ref)))
    assert worst < 1e-9
    assert mp.stats["certified"] + mp.stats["tree"] == 90 * n_pts


def _prj_reference(Re, te, Rg, tg, K, pts):
    """Mean distance of the points projected with both poses (one pair, plain numpy)."""
    ue, ug = (pts @ Re.T + te) @ K.T, (pts @ Rg.T + tg) @ K.T
    return np.linalg.norm(ue[:, :2] / ue[:, 2:] - ug[:, :2] / ug[:, 2:], axis=1).mean()


def test_numba_and_scipy_backends_agree_with_prj():
    """Both backends, and the compiled PRJ against a numpy reference, give the same numbers to 1e-9."""
    rng = np.random.default_rng(6)
    pts = _cloud(rng, 1500)
    Re, te, Rg, tg = _random_pairs(rng, 50, 5.0, 2.0)
    a = pose_errors(Re, te, Rg, tg, K, ModelPoints(pts, backend="numba"))
    b = pose_errors(Re, te, Rg, tg, K, ModelPoints(pts, backend="scipy"))
    prj_np = np.array([_prj_reference(Re[j], te[j], Rg[j], tg[j], K, pts) for j in range(len(Re))])
    for k in a:
        assert np.max(np.abs(a[k] - b[k])) < 1e-9, k
    assert np.max(np.abs(a["prj_px"] - prj_np)) < 1e-9


@pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="needs Blender (bpy)")
def test_numba_kernels_use_openmp_beside_blender():
    """bpy (in-process synthesis) loads its own, older libtbb; numba's default layer order would take
    it (measured: threading_layer() == "tbb" after `import bpy`, and `ycbvss validate` printed numba's
    "TBB threading layer requires TBB version 2021 update 6" warning). The metrics put OpenMP first."""
    import subprocess
    import sys

    code = ("import warnings; warnings.simplefilter('always'); import bpy, numba, numpy as np\n"
            "from ycbvss.eval.metrics import prj_px\n"
            "K = np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]]); R = np.stack([np.eye(3)] * 64)\n"
            "t = np.tile([0.0, 0.0, 800.0], (64, 1)); prj_px(R, t, R, t + 1.0, K, np.ones((500, 3)))\n"
            "print('LAYER', numba.threading_layer())")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "LAYER omp" in r.stdout or "LAYER workqueue" in r.stdout, r.stdout
    assert "TBB" not in r.stderr, r.stderr[-2000:]
