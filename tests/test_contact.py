"""refine.contact: signed distance, Jacobians against finite differences, and a solve that pushes a
box out of the box it was sunk into (and leaves a touching one where it is)."""
import numpy as np
import trimesh

from ycbvss.geometry.se3 import exp_se3
from ycbvss.refine.contact import ContactTerm, contact_groups, contact_surface
from ycbvss.refine.problem import BundleProblem, View
from ycbvss.refine.solver import SolverOptions, assemble, run_lm


def _problem(T_small: np.ndarray, free=(False, True)) -> tuple[BundleProblem, ContactTerm]:
    base = trimesh.creation.box(extents=(100.0, 100.0, 100.0))      # top face at z = 50 mm
    small = trimesh.creation.box(extents=(40.0, 40.0, 40.0))
    surfaces = [contact_surface(base), contact_surface(small)]
    view = View(0, np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]]), 640, 480)
    pb = BundleProblem([view], [1, 2], np.eye(4)[None], np.stack([np.eye(4), T_small]),
                       cam_free=np.zeros(1, bool), obj_free=np.array(free))
    term = ContactTerm(surfaces, contact_groups(pb, surfaces, [s.points[::4] for s in surfaces]), weight=1.0, tol_mm=1.0)
    return pb, term


def _at(z_mm: float, yaw_deg: float = 10.0) -> np.ndarray:
    T = exp_se3(np.array([5.0, -8.0, 0.0, 0.0, 0.0, np.radians(yaw_deg)]))
    T[2, 3] = z_mm
    return T


def test_signed_distance_of_a_box_is_exact_on_its_faces():
    s = contact_surface(trimesh.creation.box(extents=(100.0, 100.0, 100.0)))
    d, n = s.signed_distance(np.array([[0.0, 0.0, 47.0], [10.0, -5.0, 53.5], [0.0, 44.0, 0.0]]))
    assert np.allclose(d, [-3.0, 3.5, -6.0], atol=1e-9)
    assert np.allclose(n[0], [0, 0, 1]) and np.allclose(n[2], [0, 1, 0])


def test_gradient_matches_finite_differences(fd_gradient):
    pb, term = _problem(_at(70.0 - 6.0), free=(True, True))     # the small box 6 mm into the big one
    c0, lins = term.linearize(pb)
    assert c0 > 0 and np.isclose(c0, term.cost(pb))
    _, g = assemble(pb.n_blocks, lins)
    num = fd_gradient(pb, term, 1e-5)
    assert np.allclose(g, num, rtol=1e-4, atol=1e-6 * np.abs(num).max())


def test_solve_pushes_a_sunk_box_out_and_keeps_a_touching_one():
    pb, term = _problem(_at(70.0 - 12.0))          # 12 mm inside the base
    run_lm(pb, [term], SolverOptions(max_iters=30))
    z = pb.T_m[1][2, 3]
    assert 70.0 - 1.0 - 0.05 <= z <= 70.0 - 0.9         # out to the tolerance (1 mm), not beyond
    assert np.allclose(pb.T_m[0], np.eye(4))                # the fixed base has not moved

    pb, term = _problem(_at(70.0 - 0.5))                      # touching, 0.5 mm in: within the tolerance
    T0 = pb.T_m.copy()
    c, lins = term.linearize(pb)
    assert c == 0.0 and not lins
    run_lm(pb, [term], SolverOptions(max_iters=5))
    assert np.array_equal(pb.T_m, T0)


def test_far_objects_form_no_pairs():
    pb, term = _problem(_at(400.0))
    assert term.groups == []


def test_real_scans_no_false_inside_and_solid_interiors_found(ycbv_root):
    """On the 21 YCB-V scans (non-watertight textured meshes, some faces flipped): points 2 mm outside
    the surface along its normal almost never read inside (the nearest-8 vote; measured max 0.17 %,
    the master chef can), points 2 mm inside the solid boxes and bottles almost always do (measured
    >= 99.5 %). Thin-walled objects (bowl, mug) are left out of the second check: 2 mm inside their
    walls is through them."""
    from ycbvss.io.ycbv import load_ycbv_models

    models = load_ycbv_models(ycbv_root)
    assert len(models) == 21
    rng = np.random.default_rng(3)
    solid = {"003_cracker_box", "004_sugar_box", "006_mustard_bottle", "008_pudding_box", "009_gelatin_box",
             "011_banana", "036_wood_block"}
    assert solid <= {m.name for m in models.values()}
    for o, m in models.items():
        s = contact_surface(m.mesh)
        i = rng.choice(len(s.points), 2000, replace=False)
        d_out, _ = s.signed_distance(s.points[i] + 2.0 * s.normals[i])
        assert np.mean(d_out < -0.5) <= 0.005, m.name
        assert np.median(np.abs(d_out - 2.0)) < 0.05, m.name          # mm: exact off flat patches
        if m.name in solid:
            d_in, _ = s.signed_distance(s.points[i] - 2.0 * s.normals[i])
            assert np.mean(d_in < -0.5) >= 0.98, m.name


def test_penetration_depth_skips_only_points_that_cannot_be_inside():
    s = contact_surface(trimesh.creation.box(extents=(100.0, 100.0, 100.0)))
    rng = np.random.default_rng(3)
    Y = rng.uniform(-80.0, 80.0, size=(4000, 3))                 # about 1 in 4 inside the box
    p, n = s.penetration_depth(Y)
    d, n_ref = s.signed_distance(Y)
    inside_box = np.all(np.abs(Y) <= 50.0, axis=1)
    # inside the samples' box: exactly the signed distance's depth; outside: 0 without a lookup
    assert np.array_equal(p[inside_box], np.maximum(-d[inside_box], 0.0))
    assert np.array_equal(n[inside_box], n_ref[inside_box])
    assert np.all(p[~inside_box] == 0.0) and np.all(n[~inside_box] == 0.0)
    # and the signed distance agrees that those points are not inside
    assert np.all(d[~inside_box] >= 0.0)
    assert 0.15 < inside_box.mean() < 0.35 and np.all(p >= 0.0) and p.max() > 10.0
