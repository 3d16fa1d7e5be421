"""refine.table_contact's stacked rest (RefineOptions.stack_rest): a box standing on a box is held
on its top face, two-sided -- gap, gradient against finite differences, and a solve that brings a
lifted box down and a sunk one up to the face."""
import numpy as np
import trimesh

from ycbvss.geometry.se3 import exp_se3
from ycbvss.refine.contact import contact_surface
from ycbvss.refine.problem import BundleProblem, View
from ycbvss.refine.solver import SolverOptions, run_lm
from ycbvss.refine.table_contact import TableContactTerm, stacked_gap

UP = np.array([0.0, 0.0, 1.0])


def _problem(z_mm: float, yaw_deg: float = 10.0, tilt_deg: float = 0.0) -> tuple[BundleProblem, TableContactTerm]:
    base = trimesh.creation.box(extents=(100.0, 100.0, 100.0))      # top face at z = 50 mm
    small = trimesh.creation.box(extents=(40.0, 40.0, 40.0))        # bottom face at z = -20 mm
    T = exp_se3(np.array([5.0, -8.0, 0.0, np.radians(tilt_deg), 0.0, np.radians(yaw_deg)]))
    T[2, 3] = z_mm
    view = View(0, np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]]), 640, 480)
    pb = BundleProblem([view], [1, 2], np.eye(4)[None], np.stack([np.eye(4), T]),
                       cam_free=np.zeros(1, bool), obj_free=np.array([False, True]))
    hull = np.asarray(small.convex_hull.vertices, np.float64)
    term = TableContactTerm(UP, [], sigma_mm=0.5, stacked=[(1, hull, 0, contact_surface(base))])
    return pb, term


def test_gap_is_the_height_above_the_top_face():
    for z, want in ((70.0, 0.0), (73.5, 3.5), (68.0, -2.0)):
        pb, term = _problem(z)
        gap, W, n = stacked_gap(pb.T_m[1], term.stacked[0][1], pb.T_m[0], term.stacked[0][3], UP)
        assert abs(gap - want) < 1e-6 and np.allclose(n, UP) and abs(W[2] - (z - 20.0)) < 1e-6
        assert np.isclose(term.cost(pb), (want / 0.5) ** 2) and term.n_obs() == 1


def test_gradient_matches_finite_differences(fd_gradient):
    from ycbvss.refine.solver import assemble

    pb, term = _problem(72.0, tilt_deg=3.0)
    c0, lins = term.linearize(pb)
    assert c0 > 0 and np.isclose(c0, term.cost(pb))
    _, g = assemble(pb.n_blocks, lins)
    num = fd_gradient(pb, term, 1e-5)
    assert np.allclose(g, num, rtol=1e-4, atol=1e-6 * np.abs(num).max())


def test_a_lifted_box_comes_down_and_a_sunk_one_is_pushed_up():
    from ycbvss.refine.solver import assemble

    for z0, sign in ((76.0, -1.0), (66.0, 1.0)):
        pb, term = _problem(z0)
        _, g = assemble(pb.n_blocks, term.linearize(pb)[1])
        assert np.sign(-g[2]) == sign                          # the descent direction moves it towards the face
    pb, term = _problem(76.0)
    run_lm(pb, [term], SolverOptions(max_iters=20))            # alone (no image terms) it may also turn the box
    gap = stacked_gap(pb.T_m[1], term.stacked[0][1], pb.T_m[0], term.stacked[0][3], UP)[0]
    assert abs(gap) < 0.01 and np.allclose(pb.T_m[0], np.eye(4))
