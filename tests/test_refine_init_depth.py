"""The scene-consistent initialisation's depth anchor (refine.terms.DepthTerm, refine.init).

Pure math on synthetic point-cloud objects: no images, so no renderer is involved. DepthTerm's
gradient is checked with the other terms' in ``test_refine_jacobians.py``."""
from __future__ import annotations

import numpy as np
import pytest

from ycbvss.geometry.se3 import make_T
from ycbvss.geometry.so3 import exp_so3
from ycbvss.pipeline.perturb import perturb_poses
from ycbvss.refine.init import initialise
from ycbvss.refine.problem import View

K = np.array([[1066.8, 0, 313.0], [0, 1067.5, 241.3], [0, 0, 1]])


def _scene(n_views: int, arc_deg: float, rng: np.random.Generator):
    """Five box-shaped point clouds (50-160 mm) around the origin, cameras on an arc 1 m away."""
    Xs, T_ms = [], []
    for _ in range(5):
        Xs.append(rng.uniform(-0.5, 0.5, (150, 3)) * rng.uniform(50, 160, 3))
        T_ms.append(make_T(exp_so3(rng.normal(0, 1, 3)),
                           np.r_[rng.uniform(-150, 150), rng.uniform(-60, 60), rng.uniform(-80, 80)]))
    gt = {}
    for i in range(n_views):
        a = np.radians(-arc_deg / 2 + arc_deg * i / (n_views - 1))
        c = np.r_[1000 * np.sin(a), -400, -900 * np.cos(a)]
        z = -c / np.linalg.norm(c)
        x = np.cross([0, 1, 0], z)
        x /= np.linalg.norm(x)
        R = np.stack([x, np.cross(z, x), z])
        for j in range(5):
            gt[(i, j)] = make_T(R, -R @ c) @ T_ms[j]
    return Xs, gt


@pytest.mark.parametrize("n_views,arc_deg", [(30, 20.0), (60, 60.0)])
def test_consensus_depth_follows_the_observations(n_views, arc_deg):
    """The paper's initial error (mean ADD 22.1 mm, PRJ 5.2 px) drawn per (view, object): with the
    depth anchor the consensus's mean depth error equals the observations' within 1.5 mm (measured
    0.1-1.0 mm over these seeds); the reprojection cost alone left it 1.3-4.3 mm deeper here, and
    +1 to +12 mm deeper on the suite's clips."""
    dev_anchor, dev_reproj = [], []
    for seed in range(3):
        Xs, gt = _scene(n_views, arc_deg, np.random.default_rng(100 + seed))
        obs = perturb_poses(gt, {k: K for k in gt}, dict(enumerate(Xs)), 22.1, 5.2, seed=seed).poses
        views = [View(i, K, 640, 480) for i in range(n_views)]
        dz_obs = np.mean([obs[k][2, 3] - gt[k][2, 3] for k in gt])
        for w, out in ((0.05, dev_anchor), (0.0, dev_reproj)):
            pb, known = initialise(views, 5, dict(obs), Xs, depth_weight=w)
            assert known.all()
            out.append(np.mean([pb.pose(*k)[2, 3] - gt[k][2, 3] for k in gt]) - dz_obs)
    assert max(abs(d) for d in dev_anchor) <= 1.5, dev_anchor
    assert np.mean(dev_reproj) >= 1.0, dev_reproj        # the bias the anchor removes is present here


def test_consensus_is_the_same_at_half_the_image_width():
    """The init's truncation (px) and depth weight (per mm^2 against 1 per px^2) are set at 640 px;
    ``px_scale`` = width / 640 keeps the cost's shape when the same views are taken at 320 px (K
    halved: every pixel residual halves). The consensus then matches the 640-px one to within
    0.05 mm (measured 1e-12 mm: the same cost up to a factor); left at 640-px values the depth
    anchor weighs 4 times as much and the truncation covers twice the angle at 320 px, and the
    consensus lands elsewhere (measured: poses up to 12.1-12.3 mm apart here)."""
    K_half = K.copy()
    K_half[:2] *= 0.5
    d_scaled, d_fixed = [], []
    for seed in range(2):
        Xs, gt = _scene(30, 20.0, np.random.default_rng(200 + seed))
        obs = perturb_poses(gt, {k: K for k in gt}, dict(enumerate(Xs)), 22.1, 5.2, seed=seed).poses
        full, _ = initialise([View(i, K, 640, 480) for i in range(30)], 5, dict(obs), Xs)
        views_half = [View(i, K_half, 320, 240) for i in range(30)]
        half, _ = initialise(views_half, 5, dict(obs), Xs, px_scale=0.5)
        half_fixed, _ = initialise(views_half, 5, dict(obs), Xs)
        for pb, out in ((half, d_scaled), (half_fixed, d_fixed)):
            out.append(max(np.linalg.norm(pb.pose(*k)[:3, 3] - full.pose(*k)[:3, 3]) for k in gt))
    assert max(d_scaled) <= 0.05, d_scaled
    assert min(d_fixed) >= 1.0, d_fixed        # the mismatch px_scale removes is present here
