"""What a silhouette sees of a turn about an axis of symmetry (``RefineOptions.edge_contour_slide``).

f_edge's contour samples are model points (mm) lifted from a template: each sits where the viewing
ray grazed the surface when the template was rendered, and the Newton step moves it rigidly with
the object. For most motions that is the silhouette's motion to first order. For a turn about the
axis of a surface of revolution it is not: the surface slides along itself, and its silhouette does
not move at all. The rigidly moved sample does, by the turn times its distance from the axis times
the sine of its angle from the true rim -- a discretisation error (the sample is a pixel's width
from the rim, a grazing angle of ~25 deg on the 9 mm radius of the large marker at 1 m) that gives
the contour a false grip on the turn. Where the contour's appearance prediction is off by a tenth of
a pixel, that grip turns the object (the large marker on medium and wide bundles: -4 deg from the
exact ground truth on ycbv21-fresh2 medium-43, session 76).

A silhouette moves only with the surface's normal velocity. For a turn w about the unit axis ``a``
through ``o`` (model frame) the surface point Xs with unit normal N moves along its normal by
w ((a x (Xs - o)) . N): zero on a surface of revolution, the full rigid motion on a face the turn
pushes head-on (the marker's clip). :func:`slide_velocity` gives that normal velocity per unit turn
at each contour sample's foot on the surface, and :func:`apply_slide` replaces the rigid turn
response of the samples' Jacobians by it; every other motion keeps its rigid response. Only the
Jacobians change (the Newton step); the cost stays the rigid samples' cost.
"""
from __future__ import annotations

import weakref

import numpy as np
from scipy.spatial import cKDTree

# surface samples per model for the nearest-normal look-up (about 0.5 mm apart on a YCB-V object)
N_SURFACE_SAMPLES = 200_000

_CACHE: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def surface_index(mesh) -> tuple[cKDTree, np.ndarray]:
    """(KD-tree of ``N_SURFACE_SAMPLES`` points spread evenly by area over ``mesh``, each point's
    face index (M,)); ``mesh`` a ``trimesh.Trimesh`` in mm (cached per mesh object, seed fixed)."""
    hit = _CACHE.get(mesh)
    if hit is None:
        import trimesh

        P, fi = trimesh.sample.sample_surface(mesh, N_SURFACE_SAMPLES, seed=0)
        hit = (cKDTree(np.asarray(P, np.float64)), np.asarray(fi, np.int64))
        _CACHE[mesh] = hit
    return hit


def surface_foot(mesh, X_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Foot points F (K, 3) mm and unit surface normals N (K, 3) of points X (K, 3) mm near the
    surface of ``mesh``: X dropped onto the plane of the face of its nearest surface sample, and the
    mesh's vertex normals interpolated there (barycentric; the smooth surface the scan stands for)."""
    tree, fi = surface_index(mesh)
    _, nn = tree.query(X_mm)
    f = fi[nn]
    tri = np.asarray(mesh.vertices, np.float64)[np.asarray(mesh.faces)[f]]       # (K, 3, 3)
    nf = np.asarray(mesh.face_normals, np.float64)[f]
    F = X_mm - np.einsum("ki,ki->k", X_mm - tri[:, 0], nf)[:, None] * nf
    # barycentric coordinates of F in its face (clipped to it), then the vertex normals there
    e1, e2, r = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0], F - tri[:, 0]
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    r1, r2 = (r * e1).sum(1), (r * e2).sum(1)
    den = np.where(np.abs(d11 * d22 - d12 * d12) > 1e-18, d11 * d22 - d12 * d12, 1.0)
    b1, b2 = (d22 * r1 - d12 * r2) / den, (d11 * r2 - d12 * r1) / den
    b = np.clip(np.stack([1.0 - b1 - b2, b1, b2], 1), 0.0, None)
    b /= np.maximum(b.sum(1, keepdims=True), 1e-12)
    vn = np.asarray(mesh.vertex_normals, np.float64)[np.asarray(mesh.faces)[f]]   # (K, 3, 3)
    N = np.einsum("kv,kvi->ki", b, vn)
    N /= np.maximum(np.linalg.norm(N, axis=1, keepdims=True), 1e-12)
    return F, N


def slide_velocity(P_mm: np.ndarray, N: np.ndarray, axis: np.ndarray, offset_mm: np.ndarray) -> np.ndarray:
    """(K, 3) mm/rad: the normal velocity ((a x (P - o)) . N) N, per unit turn about the unit
    ``axis`` a through ``offset_mm`` o, of surface points P (K, 3) with unit normals N (K, 3), all
    in the model frame."""
    v = np.cross(np.asarray(axis, np.float64)[None, :], P_mm - np.asarray(offset_mm, np.float64)[None, :])
    return np.einsum("ki,ki->k", v, N)[:, None] * N


def slide_delta(mesh, X_mm: np.ndarray, contour: np.ndarray, axis: np.ndarray,
                offset_mm: np.ndarray) -> np.ndarray:
    """(K, 3) mm/rad, model frame: for each sample X (K, 3) of a group, the rigid velocity per unit
    turn about ``axis`` through ``offset_mm`` minus the velocity its silhouette really has
    (:func:`slide_velocity` at its foot on the surface, :func:`surface_foot`) for the contour samples (``contour``
    (K,) bool), zero for the others (interior edges move rigidly)."""
    X = np.asarray(X_mm, np.float64)
    a = np.asarray(axis, np.float64)
    a = a / np.linalg.norm(a)
    o = np.asarray(offset_mm, np.float64)
    out = np.zeros_like(X)
    idx = np.flatnonzero(np.asarray(contour, bool))
    if len(idx) == 0:
        return out
    F, N = surface_foot(mesh, X[idx])
    rigid = np.cross(a[None, :], X[idx] - o[None, :])
    out[idx] = rigid - slide_velocity(F, N, a, o)
    return out


def apply_slide(Jc: np.ndarray, Jo: np.ndarray, delta_mm: np.ndarray, R_c: np.ndarray, R_m: np.ndarray,
                axis: np.ndarray) -> None:
    """In place: replace the rigid turn response of point Jacobians Jc, Jo (K, 2, 6; left se(3)
    increments (v, w) of the camera, in its frame, and of the object, in the world frame, as
    :func:`ycbvss.refine.jacobians.object_point_jacobians`) by the silhouette's.

    The turn about the model axis a is the direction d_o = (c x w_o, w_o), w_o = R_m a, of the
    object's increment (c its axis point in the world) and d_c = (c_c x w_c, w_c), w_c = R_c R_m a,
    of the camera's; its rigid response J d = (d u / d Y) R_c R_m (a x (X - o)). Each row loses
    delta = (d u / d Y) R_c R_m ``delta_mm`` (K, 2) along the dual direction (0, w): J <- J - delta
    (0, w)^T. Then J d is the silhouette's response, and translations and turns about axes
    orthogonal to a through c keep theirs."""
    a = np.asarray(axis, np.float64)
    a = a / np.linalg.norm(a)
    w_o = R_m @ a
    w_c = R_c @ w_o
    # Jo[:, :, :3] = (d u / d Y) R_c, the response to a world-frame displacement
    dW = np.asarray(delta_mm, np.float64) @ R_m.T
    delta = np.einsum("kij,kj->ki", Jo[:, :, :3], dW)
    Jo[:, :, 3:] -= delta[:, :, None] * w_o[None, None, :]
    Jc[:, :, 3:] -= delta[:, :, None] * w_c[None, None, :]
