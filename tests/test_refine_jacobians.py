"""Analytic Jacobians and term gradients of the bundle refinement vs finite differences (< 2 s)."""
from __future__ import annotations

import cv2
import numpy as np

from ycbvss.geometry.se3 import exp_se3, make_T
from ycbvss.refine.edge import EdgeField, edge_field
from ycbvss.refine.jacobians import object_point_jacobians, transfer_point_jacobians
from ycbvss.refine.problem import BundleProblem, View
from ycbvss.refine.solver import assemble
from ycbvss.refine.terms import (DepthGroup, DepthTerm, EdgeGroup, EdgeTerm, PointGroup, PointTerm, TemporalGroup,
                                 TemporalTerm)

K = np.array([[500.0, 0, 160], [0, 505.0, 120], [0, 0, 1]])


def _poses(rng):
    Tc = exp_se3(np.r_[rng.normal(scale=20, size=3), rng.normal(scale=0.1, size=3)])
    Tm = make_T(np.eye(3), [0, 0, 600]) @ exp_se3(np.r_[rng.normal(scale=5, size=3), rng.normal(scale=0.5, size=3)])
    return Tc, Tm


def test_projection_jacobians_match_finite_differences():
    rng = np.random.default_rng(1)
    Tc, Tm = _poses(rng)
    X = rng.normal(scale=40, size=(20, 3))
    _, Jc, Jo, ok = object_point_jacobians(K, Tc, Tm, X)
    assert ok.all()
    h, worst = 1e-6, 0.0
    for k in range(6):
        e = np.zeros(6)
        e[k] = h
        fc = (object_point_jacobians(K, exp_se3(e) @ Tc, Tm, X)[0] - object_point_jacobians(K, exp_se3(-e) @ Tc, Tm, X)[0]) / (2 * h)
        fo = (object_point_jacobians(K, Tc, exp_se3(e) @ Tm, X)[0] - object_point_jacobians(K, Tc, exp_se3(-e) @ Tm, X)[0]) / (2 * h)
        worst = max(worst, np.abs(fc - Jc[:, :, k]).max(), np.abs(fo - Jo[:, :, k]).max())
    assert worst < 1e-5 * max(1.0, np.abs(Jc).max())
    Tk = exp_se3(np.r_[15, -5, 3, 0.05, -0.02, 0.03])
    Yk = rng.normal(scale=40, size=(20, 3)) + [0, 0, 600]
    _, Ji, Jk, ok = transfer_point_jacobians(K, Tc, Tk, Yk)
    worst = 0.0
    for k in range(6):
        e = np.zeros(6)
        e[k] = h
        fi = (transfer_point_jacobians(K, exp_se3(e) @ Tc, Tk, Yk)[0] - transfer_point_jacobians(K, exp_se3(-e) @ Tc, Tk, Yk)[0]) / (2 * h)
        fk = (transfer_point_jacobians(K, Tc, exp_se3(e) @ Tk, Yk)[0] - transfer_point_jacobians(K, Tc, exp_se3(-e) @ Tk, Yk)[0]) / (2 * h)
        worst = max(worst, np.abs(fi - Ji[:, :, k]).max(), np.abs(fk - Jk[:, :, k]).max())
    assert worst < 1e-5 * max(1.0, np.abs(Ji).max())


def _problem(rng, two_views=True):
    views = [View(0, K, 320, 240), View(1, K, 320, 240)]
    Tc, Tm = _poses(rng)
    return BundleProblem(views, [1], np.stack([np.eye(4), Tc]), Tm[None])


def test_term_gradients_match_finite_differences(fd_gradient):
    rng = np.random.default_rng(2)
    pb = _problem(rng)
    X = rng.normal(scale=30, size=(60, 3))
    # smooth edge field (blurred noise) so that the sampled derivatives are accurate
    img = cv2.GaussianBlur((rng.random((240, 320)) * 255).astype(np.float32), (0, 0), 6)
    img = (255 * (img - img.min()) / np.ptp(img)).astype(np.uint8)
    f = edge_field(img, 4.0)
    terms = [EdgeTerm([f, f], [EdgeGroup(0, 0, X), EdgeGroup(1, 0, X)]),
             PointTerm([PointGroup(1, 0, X, object_point_jacobians(K, pb.T_c[1], pb.T_m[0], X)[0]
                                   + rng.normal(scale=3, size=(60, 2)))], rho=0.25, floor_px=0.0),
             TemporalTerm([TemporalGroup(1, 0, X + [0, 0, 600], transfer_point_jacobians(K, pb.T_c[1], pb.T_c[0], X + [0, 0, 600])[0]
                                         + rng.normal(scale=3, size=(60, 2)))], rho=0.25, floor_px=0.0)]
    # the floored (C1, quadratic below the floor) robust cost: its IRLS gradient is exact too
    terms.append(PointTerm([PointGroup(1, 0, X, terms[1].groups[0].x)], rho=0.25, floor_px=4.0))
    for term, h, tol in ((terms[0], 1e-4, 0.1), (terms[1], 1e-6, 1e-3), (terms[2], 1e-6, 1e-3),
                         (terms[3], 1e-6, 1e-3)):
        _, lins = term.linearize(pb)
        _, g = assemble(pb.n_blocks, lins)
        g_fd = fd_gradient(pb, term, h)
        rel = np.linalg.norm(g - g_fd) / np.linalg.norm(g_fd)
        assert rel < tol, (term.name, rel)


def test_depth_term_gradient_matches_finite_differences(fd_gradient):
    """DepthTerm (the initialisation's depth anchor), points beyond its cap included (no gradient)."""
    rng = np.random.default_rng(0)
    pb = _problem(rng)
    X = rng.normal(size=(40, 3)) * 40
    z = [X @ pb.pose(i, 0)[2, :3] + pb.pose(i, 0)[2, 3] + rng.normal(size=40) * 5 for i in range(2)]
    z[1][:3] += 500.0      # three outliers beyond the cap
    term = DepthTerm([DepthGroup(i, 0, X, z[i]) for i in range(2)], weight=0.3, cap_mm=60.0)
    _, lins = term.linearize(pb)
    _, g = assemble(pb.n_blocks, lins)
    assert np.abs(fd_gradient(pb, term, 1e-6) - g).max() <= 1e-5 * np.abs(g).max()


def test_uniform_image_gives_flat_edge_field():
    f = edge_field(np.full((40, 50, 3), 128, np.uint8), 1.0)
    assert isinstance(f, EdgeField)
    assert float(np.abs(f.E - 1.0).max()) == 0.0 and float(np.abs(f.data[..., 1:]).max()) == 0.0


def test_se3_jac_kernel_matches_array_form():
    """The compiled M @ [I, -[P]x] gives the array form's numbers exactly, and equals the explicit
    product with the skew matrix to rounding."""
    from ycbvss.refine.jacobians import _se3_jac

    rng = np.random.default_rng(4)
    for rows in (1, 2):
        M = rng.normal(size=(500, rows, 3))
        P = rng.normal(0, 300, size=(500, 3))
        ref = np.empty((500, rows, 6))
        ref[:, :, :3] = M
        P0, P1, P2 = P[:, 0, None], P[:, 1, None], P[:, 2, None]
        r0, r1, r2 = M[:, :, 0], M[:, :, 1], M[:, :, 2]
        ref[:, :, 3], ref[:, :, 4], ref[:, :, 5] = P1 * r2 - P2 * r1, P2 * r0 - P0 * r2, P0 * r1 - P1 * r0
        got = _se3_jac(M, P, np.empty((500, rows, 6)))
        assert np.array_equal(got, ref)
        skew = np.zeros((500, 3, 3))
        skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -P[:, 2], P[:, 1], -P[:, 0]
        skew -= np.swapaxes(skew, 1, 2)
        full = np.concatenate([M, -M @ skew], axis=2)
        assert np.abs(got - full).max() < 1e-9 * np.abs(full).max()
