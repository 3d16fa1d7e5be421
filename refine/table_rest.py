"""An object standing on the table rests on one of its stable faces (``RefineOptions.table_rest``).

An object lying on a table touches it with a face of its convex hull (for a banana: three points;
for a box: its face) whose outward normal points straight down, and only the faces on which it can
stand (the centre of mass projects inside them) occur. With a short viewing baseline the images fix
such an object's tilt badly: a flat, weakly textured object can roll about its long axis at almost
no cost in its silhouette. Measured (suite short-1, paper init, seeds 0, 1, 5): the banana lying on
the table ends 4.7 deg rolled, the same in every view and seed, and the short clips' rotation
errors are mostly tilt (rotation about axes in the table plane; ``bench/rest_facets.py``).

This term holds the tilt of each object that touches the support plane (``refine.table_contact``)
to its nearest stable face, with the precision the model allows:

    f_rest = weight * rho(|L^T tau|^2),    tau = S R_r R^T (-n)

``n`` the table's measured unit normal (world, towards the cameras), ``R`` the object's orientation
(model to world), ``R_r`` the rotation that sets the model on that face (face normal to -z, trimesh's
stable poses of the convex hull), ``S`` picks the tilt (the x, y components of (-z) x d, rad for
small tilts). ``L L^T`` is the tilt's information: a least-squares plane through the face's contact
points, each uncertain by the model's accuracy ``acc_mm``: the corners of the support polygon (hull
vertices within ``acc_mm`` of the face), their in-plane offsets p from their mean, worth three
independent contacts, info = 3 mean(p p^T) / acc^2 (a 50 mm square face, 1 mm: 1.3 deg). ``rho``
is Geman-McClure with scale ``c`` (in those sigmas), so an object that does not rest on a face (it
leans on another, or stands on an uneven support) is let go instead of pulled flat.

Left increments in world coordinates (R <- exp(w) R): d tau / d w = -S R_r R^T [n]_x.
"""
from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np

from scipy.spatial import ConvexHull, QhullError

from ..geometry.so3 import hat
from .problem import BundleProblem
from .support import nearest_gap_mm

_S = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])     # (-z) x d = (d_y, -d_x, 0)
_CACHE: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class RestFaces:
    """The stable resting faces of a model: per face the rotation (3, 3) that turns the model onto
    it (the face's outward normal to -z), the Cholesky factor L (2, 2) of the tilt's information
    (rad^-2), and its quasi-static probability."""

    R_rest: np.ndarray     # (K, 3, 3)
    L: np.ndarray          # (K, 2, 2)
    prob: np.ndarray       # (K,)

    @property
    def down(self) -> np.ndarray:
        """(K, 3) each face's outward unit normal in the model frame (down when resting on it)."""
        return -self.R_rest[:, 2, :]


def rest_faces(points_mm: np.ndarray, acc_mm: float = 1.0, center_mass_mm: np.ndarray | None = None) -> RestFaces:
    """The stable faces of the convex hull of ``points_mm`` (N, 3; model frame, mm) by trimesh's
    quasi-static stable poses, with the tilt information of a plane through each face's support
    polygon (the corners of the hull vertices within ``acc_mm`` of the face) worth three contacts,
    each uncertain by ``acc_mm``."""
    import trimesh

    none = RestFaces(np.zeros((0, 3, 3)), np.zeros((0, 2, 2)), np.zeros(0))
    P = np.asarray(points_mm, np.float64).reshape(-1, 3)
    if len(P) < 4 or not np.all(np.isfinite(P)):
        return none
    # a flat or degenerate model has no volume to stand on (its centre of mass is undefined and
    # trimesh's stable-pose search does not end on it): no faces, the term leaves it alone
    with np.errstate(invalid="ignore", divide="ignore"):         # trimesh's mass properties of a flat hull
        try:
            hull = trimesh.points.PointCloud(P).convex_hull
        except (QhullError, ValueError):
            return none
        solid = bool(hull.is_volume and hull.volume > 1e-9 * float(np.ptp(P, axis=0).max()) ** 3)
    if not solid:
        return none
    if center_mass_mm is not None and not np.all(np.isfinite(center_mass_mm)):
        center_mass_mm = None
    T, p = trimesh.poses.compute_stable_poses(hull, center_mass=center_mass_mm, n_samples=1, threshold=0.0, sigma=0.0)
    V = np.asarray(hull.vertices, np.float64)
    Rs, Ls, ps = [], [], []
    for Ti, pi in zip(T, p):
        R = np.asarray(Ti, np.float64)[:3, :3]
        W = V @ R.T
        z = W[:, 2]
        c = W[z < z.min() + acc_mm, :2]
        if len(c) < 3:
            continue
        try:
            c = c[ConvexHull(c).vertices]              # the support polygon's corners
        except QhullError:
            continue                                   # collinear: an edge, no face to rest on
        c = c - c.mean(axis=0)
        # height change of contact point (x, y) under a tilt tau (rotation vector's x, y): y tau_x - x tau_y;
        # the corners' spread, worth three independent contacts (they do not multiply with the scan's density)
        Jh = np.stack([c[:, 1], -c[:, 0]], axis=1)
        info = 3.0 * (Jh.T @ Jh) / len(c) / acc_mm ** 2
        if np.linalg.eigvalsh(info)[0] <= 0.0:
            continue
        Rs.append(R)
        Ls.append(np.linalg.cholesky(info))
        ps.append(float(pi))
    if not Rs:
        return none
    return RestFaces(np.stack(Rs), np.stack(Ls), np.asarray(ps))


def model_rest_faces(mesh, acc_mm: float = 1.0) -> RestFaces:
    """:func:`rest_faces` of a trimesh model's vertices (the centre of mass of their hull), computed
    once per mesh object and accuracy."""
    per = _CACHE.setdefault(mesh, {})
    if acc_mm not in per:
        per[acc_mm] = rest_faces(np.asarray(mesh.vertices), acc_mm)   # the hull's own centre of mass
    return per[acc_mm]


_POINTS: dict = {}     # (id of a points array, acc) -> (the array, its RestFaces)


def object_rest_faces(model, acc_mm: float = 1.0) -> RestFaces:
    """The resting faces of an :class:`ycbvss.scene.ObjectModel`: of its ``rest_points_mm`` (another
    model of the object) when given, else of its mesh (:func:`model_rest_faces`)."""
    pts = getattr(model, "rest_points_mm", None)
    if pts is None:
        return model_rest_faces(model.mesh, acc_mm)
    key = (id(pts), float(acc_mm))
    hit = _POINTS.get(key)
    if hit is None or hit[0] is not pts:
        hit = _POINTS[key] = (pts, rest_faces(np.asarray(pts, np.float64), acc_mm))
    return hit[1]


def tilt(R: np.ndarray, faces: RestFaces, n_w: np.ndarray) -> tuple[int, np.ndarray]:
    """(index of the face nearest to resting, its tilt tau (2,) rad) of an object at orientation
    ``R`` (model to world) on a plane of upward unit normal ``n_w`` (world)."""
    d = R.T @ (-np.asarray(n_w, np.float64))                       # down, model frame
    k = int(np.argmax(faces.down @ d))
    return k, _S @ (faces.R_rest[k] @ d)


def free_standing(T_m: np.ndarray, surfaces: list, points: list, held: list[int], reach_mm: float) -> frozenset:
    """The objects of ``held`` (indices into the poses ``T_m`` (J, 4, 4), model to world, mm) none
    of whose surface points ``points[j]`` (model frame, mm) lies within ``reach_mm`` of another
    object's surface (``surfaces[k]``: :class:`refine.contact.ContactSurface`, nearest sample; any
    other object with a finite pose, bounding spheres first): nothing there to lean on."""
    others = [k for k in range(len(T_m)) if np.all(np.isfinite(T_m[k]))]
    return frozenset(j for j in held if not nearest_gap_mm(T_m, surfaces, j, others, points[j], reach_mm) < reach_mm)


def geman_mcclure(s: np.ndarray | float, c: float) -> tuple:
    """rho(s) = s / (1 + s / c^2) of a squared whitened residual s, and d rho / d s."""
    q = 1.0 + np.asarray(s, np.float64) / c ** 2
    return s / q, 1.0 / q ** 2


@dataclass
class TableRestTerm:
    """``groups``: (object index j, its :class:`RestFaces`, the unit axis (3,) of its continuous
    rotational symmetry in the model frame or None) per object touching the table. A symmetric
    object lying on its side (a can, the marker) rests on any turn about that axis, but its hull's
    faces are discrete: the tilt's component about the axis is left out (where the axis lies within
    60 deg of the table plane)."""

    normal_w: np.ndarray
    groups: list = field(default_factory=list)
    scale: float = 3.0
    weight: float = 1.0
    name: str = "table_rest"
    # object indices held without the let-go (rho(s) = s): objects with nothing else within reach
    # to lean on (RefineOptions.table_rest_lean_mm), which can only rest on a face
    free_standing: frozenset = frozenset()

    def _rho(self, j: int, s: float) -> tuple[float, float]:
        """(rho, d rho / d s) of object j's squared whitened tilt ``s``: Geman-McClure, or the plain
        square for a free-standing object."""
        return (s, 1.0) if j in self.free_standing else geman_mcclure(s, self.scale)

    def n_obs(self) -> int:
        return len(self.groups)

    def _residuals(self, pb: BundleProblem) -> list[tuple[int, np.ndarray, np.ndarray]]:
        """(object index, whitened tilt e (2,), d e / d w (2, 3)) of each finite pose."""
        out = []
        for j, faces, axis in self.groups:
            R = pb.T_m[j][:3, :3]
            if not np.all(np.isfinite(R)) or len(faces.prob) == 0:
                continue
            k, tau = tilt(R, faces, self.normal_w)
            P = np.eye(2)
            if axis is not None:
                v = (faces.R_rest[k] @ axis)[:2]               # the axis' in-plane part (rest frame)
                if np.linalg.norm(v) > 0.5:
                    u = v / np.linalg.norm(v)
                    P = P - np.outer(u, u)
            Lt = faces.L[k].T @ P
            J = -Lt @ _S @ faces.R_rest[k] @ R.T @ hat(self.normal_w)
            out.append((j, Lt @ tau, J))
        return out

    def cost(self, pb: BundleProblem) -> float:
        return self.weight * float(sum(self._rho(j, float(e @ e))[0] for j, e, _ in self._residuals(pb)))

    def linearize(self, pb: BundleProblem) -> tuple[float, list]:
        from .terms import Linearization
        out, total = [], 0.0
        for j, e, Jw in self._residuals(pb):
            rho, drho = self._rho(j, float(e @ e))
            total += rho
            J = np.zeros((1, 2, 6))
            J[0, :, 3:] = Jw
            A = (2.0 * self.weight * drho * np.eye(2))[None]          # IRLS: the Gauss-Newton part, PSD
            g = (2.0 * self.weight * drho * e)[None]
            out.append(Linearization(int(pb.obj_block[j]), -1, J, np.zeros((1, 2, 6)), A, g))
        return self.weight * total, out
