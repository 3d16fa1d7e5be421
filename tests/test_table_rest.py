"""refine.table_rest (RefineOptions.table_rest): an object on the table held on its nearest stable
face -- the faces and their tilt precision, the tilt itself, the gradient against finite
differences, a solve that lays a tilted box flat, the robust kernel letting go of an object far
from any face, and holding one that has nothing to lean on."""
import numpy as np
import trimesh

from ycbvss.geometry.se3 import exp_se3
from ycbvss.refine.problem import BundleProblem, View
from ycbvss.refine.solver import SolverOptions, assemble, run_lm
from ycbvss.refine.table_rest import TableRestTerm, geman_mcclure, rest_faces, tilt

UP = np.array([0.0, 0.0, 1.0])
BOX = (80.0, 40.0, 20.0)          # mm


def _box_faces(acc_mm: float = 1.0):
    return rest_faces(np.asarray(trimesh.creation.box(extents=BOX).vertices, np.float64), acc_mm)


def _problem(tilt_deg: tuple[float, float], yaw_deg: float = 25.0):
    """A box lying on its largest face, yawed, then tilted about the world x and y axes."""
    T = exp_se3(np.array([10.0, -5.0, 10.0, 0.0, 0.0, np.radians(yaw_deg)]))
    Rt = exp_se3(np.r_[0.0, 0.0, 0.0, np.radians(tilt_deg[0]), np.radians(tilt_deg[1]), 0.0])
    T = Rt @ T
    view = View(0, np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]]), 640, 480)
    pb = BundleProblem([view], [1], np.eye(4)[None], T[None], cam_free=np.zeros(1, bool), obj_free=np.array([True]))
    return pb, TableRestTerm(UP, [(0, _box_faces(), None)])


def test_a_box_has_six_faces_with_the_plane_fit_precision():
    f = _box_faces(acc_mm=1.0)
    assert len(f.prob) == 6 and np.isclose(f.prob.sum(), 1.0, atol=1e-6)
    big = int(np.argmax(np.abs(f.down[:, 2])))                     # a +-z face: 80 x 40 mm
    info = f.L[big] @ f.L[big].T
    # corners (+-40, +-20): info = 3 mean(p p^T) with Jh = (y, -x): diag 3 * (20^2, 40^2)
    assert np.allclose(np.sort(np.diag(info)), [3 * 400.0, 3 * 1600.0], rtol=1e-6)
    assert abs(info[0, 1]) < 1e-6


def test_tilt_is_zero_at_rest_and_the_applied_angle_when_tilted():
    f = _box_faces()
    for tx, ty in ((0.0, 0.0), (1.5, 0.0), (0.0, -2.0), (0.7, 0.4)):
        pb, _ = _problem((tx, ty))
        k, tau = tilt(pb.T_m[0][:3, :3], f, UP)
        assert abs(f.down[k, 2]) > 0.99                            # still its largest face
        assert np.isclose(np.degrees(np.linalg.norm(tau)), np.hypot(tx, ty), atol=2e-3)


def test_gradient_matches_finite_differences(fd_gradient):
    pb, term = _problem((1.2, -0.8))
    c0, lins = term.linearize(pb)
    assert c0 > 0 and np.isclose(c0, term.cost(pb))
    _, g = assemble(pb.n_blocks, lins)
    num = fd_gradient(pb, term, 1e-6)
    assert np.allclose(g, num, rtol=1e-3, atol=1e-6 * np.abs(num).max())
    assert np.allclose(g[:3], 0.0)                                 # a tilt prior does not move the box


def test_a_tilted_box_is_laid_flat_and_keeps_its_yaw():
    pb, term = _problem((1.5, -1.0), yaw_deg=25.0)
    run_lm(pb, [term], SolverOptions(max_iters=30))
    R = pb.T_m[0][:3, :3]
    k, tau = tilt(R, term.groups[0][1], UP)
    assert np.degrees(np.linalg.norm(tau)) < 0.01
    yaw = np.degrees(np.arctan2(R[1, 0], R[0, 0]))
    assert abs(yaw - 25.0) < 0.2                                   # the turn about the normal stays free


def test_the_kernel_lets_go_of_an_object_far_from_any_face():
    # pull (|gradient| of the cost in the tilt) at 1 sigma against 10 sigma
    s1, s10 = 1.0, 10.0
    g1 = 2 * s1 * geman_mcclure(s1 ** 2, 3.0)[1]
    g10 = 2 * s10 * geman_mcclure(s10 ** 2, 3.0)[1]
    assert g10 < 0.15 * g1
    pb_near, term = _problem((1.0, 0.0))
    pb_far, _ = _problem((25.0, 0.0))                             # leaning: 25 deg from the face
    gn = np.linalg.norm(assemble(1, term.linearize(pb_near)[1])[1])
    gf = np.linalg.norm(assemble(1, term.linearize(pb_far)[1])[1])
    assert gf < 0.05 * gn


def test_a_free_standing_object_is_not_let_go_and_is_laid_flat_from_far():
    # nothing to lean on: the plain square, so 25 deg from its face pulls harder than 1 deg does
    pb_near, term = _problem((1.0, 0.0))
    pb_far, _ = _problem((25.0, 0.0))
    free = TableRestTerm(UP, term.groups, free_standing=frozenset({0}))
    gn = np.linalg.norm(assemble(1, free.linearize(pb_near)[1])[1])
    gf = np.linalg.norm(assemble(1, free.linearize(pb_far)[1])[1])
    assert gf > 10.0 * gn
    c0, lins = free.linearize(pb_far)
    assert np.isclose(c0, free.cost(pb_far)) and term.cost(pb_far) < 9.0 < 0.1 * c0   # GM saturates at c^2 = 9
    # and a solve lays it flat
    pb, _ = _problem((12.0, 0.0))
    run_lm(pb, [free], SolverOptions(max_iters=50))
    assert np.degrees(np.linalg.norm(tilt(pb.T_m[0][:3, :3], term.groups[0][1], UP)[1])) < 0.01


def test_free_standing_means_no_other_surface_within_reach():
    from ycbvss.refine.contact import contact_surface
    from ycbvss.refine.table_rest import free_standing

    box = trimesh.creation.box(extents=BOX)                       # 80 x 40 x 20 mm
    surf = contact_surface(box, n_samples=4000)
    pts = [surf.points[::8]] * 3

    def at(x: float) -> np.ndarray:
        T = np.eye(4)
        T[0, 3] = x
        return T
    # box 0 at x = 0; box 1 with a 5 mm gap to it (faces at 40 and 45); box 2 200 mm away
    T_m = np.stack([at(0.0), at(85.0), at(300.0)])
    assert free_standing(T_m, [surf] * 3, pts, [0, 1, 2], 10.0) == {2}
    assert free_standing(T_m, [surf] * 3, pts, [0, 1, 2], 4.0) == {0, 1, 2}
    T_m[2] = np.nan                                               # a failed pose leans on nothing and holds nothing
    assert free_standing(T_m, [surf] * 3, pts, [0, 1], 4.0) == {0, 1}


def test_a_lying_cylinder_keeps_its_turn_about_its_axis():
    # a cylinder (axis z in the model frame) lying on its side: its hull's faces are discrete, the
    # symmetric object is not; rolled about its axis it feels no pull, tilted along its length it does
    cyl = trimesh.creation.cylinder(radius=10.0, height=120.0, sections=24)
    faces = rest_faces(np.asarray(cyl.vertices, np.float64))
    k = int(np.argmin(np.abs(faces.down[:, 2])))                 # a face along the side
    base = faces.R_rest[k].T                                      # model -> world: lying on that face
    axis = np.array([0.0, 0.0, 1.0])
    a_w = base @ axis
    for rot, pulled in ((a_w, False), (np.cross(a_w, UP), True)):
        R = exp_se3(np.r_[0.0, 0.0, 0.0, np.radians(4.0) * rot / np.linalg.norm(rot)])[:3, :3] @ base
        T = np.eye(4)
        T[:3, :3] = R
        view = View(0, np.array([[600.0, 0, 320], [0, 600.0, 240], [0, 0, 1]]), 640, 480)
        pb = BundleProblem([view], [1], np.eye(4)[None], T[None], cam_free=np.zeros(1, bool), obj_free=np.array([True]))
        c_sym = TableRestTerm(UP, [(0, faces, axis)]).cost(pb)
        c_plain = TableRestTerm(UP, [(0, faces, None)]).cost(pb)
        if pulled:
            assert c_sym > 1.0 and np.isclose(c_sym, c_plain, rtol=0.05)
        else:
            assert c_sym < 1e-9 < c_plain


def test_the_suite_takes_the_resting_faces_from_the_official_points(ycbv_root, tmp_path):
    # the suite's scenes stand on faces of the scanned mesh; the prior must come from another model
    from ycbvss.io.ycbv import load_ycbv_models
    from ycbvss.pipeline.suite import attach_official_points
    from ycbvss.refine.table_rest import object_rest_faces

    ycbv = load_ycbv_models(ycbv_root)
    models = {o: ycbv[o] for o in (10, 21)}                       # banana, foam brick (YCB-V frame, not BOP's)
    attach_official_points(models, ycbv_root)
    for o, m in models.items():
        P = m.rest_points_mm
        assert P is not None and P.shape[1] == 3 and len(P) > 1000
        mesh = m.mesh
        # the official model and the scan share the object's frame: the BOP frame is the YCB-V
        # frame moved by the model's centre, which the attached points carry
        from ycbvss.io.ycbv import model_center_mm
        gap = np.abs(np.r_[P.min(0), P.max(0)] - (mesh.bounds - model_center_mm(m.path)).ravel()).max()
        assert gap < 1.5
        own, other = object_rest_faces(SimpleModel(mesh)), object_rest_faces(m)
        assert other is not own and len(other.prob) >= 3
        # every likely face of the scan has a face of the official model within 1 deg
        ang = np.degrees(np.arccos(np.clip((own.down[own.prob > 0.1] @ other.down.T).max(axis=1), -1, 1)))
        assert ang.max() < 1.0


class SimpleModel:
    def __init__(self, mesh):
        self.mesh, self.rest_points_mm = mesh, None


def test_a_flat_or_degenerate_model_has_no_faces_and_is_left_alone():
    rng = np.random.default_rng(0)
    flat = rng.random((50, 3)) * 100.0
    flat[:, 2] = 0.0                                              # a plane: no volume, no centre of mass
    for P in (flat, flat[:3], np.full((10, 3), np.nan)):
        f = rest_faces(P)
        assert len(f.prob) == 0 and f.R_rest.shape == (0, 3, 3)
    pb, _ = _problem((2.0, 0.0))
    term = TableRestTerm(UP, [(0, rest_faces(flat), None)])
    assert term.cost(pb) == 0.0 and term.linearize(pb) == (0.0, [])
