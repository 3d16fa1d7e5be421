"""refine.contour_slide: contour samples respond to a turn about a symmetry axis as the silhouette does."""
from __future__ import annotations

import numpy as np
import trimesh

from ycbvss.geometry.so3 import exp_so3
from ycbvss.refine.contour_slide import apply_slide, slide_delta
from ycbvss.refine.jacobians import object_point_jacobians

K = np.array([[1066.8, 0.0, 313.0], [0.0, 1067.5, 241.3], [0.0, 0.0, 1.0]])
AXIS = np.array([0.0, 1.0, 0.0])     # the large marker's axis is its model y


def _poses(seed: int):
    rng = np.random.default_rng(seed)
    T_c = np.eye(4)
    T_c[:3, :3] = exp_so3(0.1 * rng.normal(size=3))
    T_c[:3, 3] = rng.normal(scale=20.0, size=3)
    T_m = np.eye(4)
    T_m[:3, :3] = exp_so3(rng.normal(size=3))
    T_m[:3, 3] = [30.0, -20.0, 900.0]
    return T_c, T_m


def _turn_directions(T_c, T_m, a):
    """The object's and the camera's se(3) increments that turn the object about its model axis a
    through the model origin (rad^-1), as refine.jacobians parametrises them."""
    w_o = T_m[:3, :3] @ a
    c = T_m[:3, 3]
    w_c = T_c[:3, :3] @ w_o
    c_c = T_c[:3, :3] @ c + T_c[:3, 3]
    return np.r_[np.cross(c, w_o), w_o], np.r_[np.cross(c_c, w_c), w_c]


def test_turn_of_a_surface_of_revolution_moves_no_contour_sample():
    cyl = trimesh.creation.cylinder(radius=9.0, height=130.0, sections=512,
                                    transform=trimesh.transformations.rotation_matrix(np.pi / 2, [1, 0, 0]))
    rng = np.random.default_rng(0)
    phi = rng.uniform(0, 2 * np.pi, 40)
    X = np.stack([9.0 * np.cos(phi), rng.uniform(-50, 50, 40), 9.0 * np.sin(phi)], 1)
    T_c, T_m = _poses(1)
    _, Jc, Jo, valid = object_point_jacobians(K, T_c, T_m, X)
    assert valid.all()
    d_o, d_c = _turn_directions(T_c, T_m, AXIS)
    rigid = np.abs(Jo @ d_o).max()
    assert rigid > 5.0          # px/rad: rigidly moved, the samples do see the turn
    Jc0, Jo0 = Jc.copy(), Jo.copy()
    apply_slide(Jc, Jo, slide_delta(cyl, X, np.ones(len(X), bool), AXIS, np.zeros(3)), T_c[:3, :3], T_m[:3, :3], AXIS)
    # a 512-gon's facet normals are within 0.35 deg of radial: < 1 % of the rigid response is left
    assert np.abs(Jo @ d_o).max() < 0.01 * rigid
    assert np.abs(Jc @ d_c).max() < 0.01 * rigid
    # every translation keeps its response exactly, of the object and of the camera
    assert np.array_equal(Jo[:, :, :3], Jo0[:, :, :3]) and np.array_equal(Jc[:, :, :3], Jc0[:, :, :3])
    # and so does a turn about an axis at right angles to a through the object's origin
    w_perp = T_m[:3, :3] @ np.array([1.0, 0.0, 0.0])
    e = np.r_[np.cross(T_m[:3, 3], w_perp), w_perp]
    assert np.allclose(Jo @ e, Jo0 @ e, atol=1e-9)


def test_face_the_turn_pushes_head_on_keeps_its_normal_motion_only():
    box = trimesh.creation.box((20.0, 100.0, 20.0))      # faces at x = +-10 and z = +-10, axis y
    box.unmerge_vertices()                               # sharp edges: each face's vertex normals are its own
    rng = np.random.default_rng(2)
    X = np.stack([np.full(30, 10.0), rng.uniform(-40, 40, 30), rng.uniform(-6, 6, 30)], 1)   # on the face x = 10
    T_c, T_m = _poses(3)
    _, Jc, Jo, _ = object_point_jacobians(K, T_c, T_m, X)
    d_o, d_c = _turn_directions(T_c, T_m, AXIS)
    apply_slide(Jc, Jo, slide_delta(box, X, np.ones(len(X), bool), AXIS, np.zeros(3)), T_c[:3, :3], T_m[:3, :3], AXIS)
    # a turn w about y moves the face x = 10 along its normal (1, 0, 0) by (a x X) . N = w z
    v = np.zeros_like(X)
    v[:, 0] = X[:, 2]
    _, _, Jv, _ = object_point_jacobians(K, T_c, T_m, X)
    want = np.einsum("kij,kj->ki", Jv[:, :, :3], v @ T_m[:3, :3].T)
    tol = 1e-6 * np.abs(want).max()
    assert np.abs(Jo @ d_o - want).max() < tol and np.abs(Jc @ d_c - want).max() < tol


def test_interior_samples_keep_their_rigid_response():
    cyl = trimesh.creation.cylinder(radius=9.0, height=130.0, sections=128)
    X = np.array([[9.0, 0.0, 10.0], [0.0, 9.0, -20.0]])
    d = slide_delta(cyl, X, np.array([False, False]), np.array([0.0, 0.0, 1.0]), np.zeros(3))
    assert np.array_equal(d, np.zeros_like(X))
