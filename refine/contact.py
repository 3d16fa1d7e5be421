"""Non-penetration of the objects of a bundle: a one-sided cost on how deep one object's surface
lies inside another.

Objects at rest touch, and stack, but do not interpenetrate. Where the images hold an object's
position only weakly along one direction -- a small object standing on a box, whose contact line
f_edge skips (``RefineOptions.edge_contact_mm``) -- nothing but this term keeps it from sinking
into the object beneath it.

Signed distance (mm) of a point Y to object k is taken point-to-plane at the nearest of k's dense
surface samples p with outward normal n: d = (Y - p) . n (negative inside), a point counting as
inside only when most of its nearest samples' planes agree (:meth:`ContactSurface.signed_distance`). It is exact on flat
faces and accurate to a fraction of the sample spacing on curved ones near the surface, which is
where the term acts; a point deep inside a thin part may find the far face and be missed, which
costs nothing worse than no term. For a model point X of object j (world point W = T_m[j] X,
Y = T_m[k]^-1 W), the penetration is p = -d and the cost

    f_contact = weight * sum max(0, p - tol_mm)^2,

zero for any pose in which no point of one object is more than ``tol_mm`` inside the other, so it
does not move objects that do not interpenetrate. Jacobians (left increments, world frame, see
:mod:`ycbvss.refine.jacobians`): dp/dxi_j = -n_w^T [I, -[W]x], dp/dxi_k = +n_w^T [I, -[W]x]
(n_w the normal in the world).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .jacobians import _se3_jac
from .problem import BundleProblem
from .terms import Linearization


@dataclass
class ContactSurface:
    """Dense surface samples of one model (model frame, mm): points (N, 3), outward unit normals
    (N, 3), their KD-tree, the bounding sphere (centre (3,), radius mm) of the points and their
    axis-aligned box in the model frame (corners ``lo``, ``hi`` (3,), mm; None: computed here)."""

    points: np.ndarray
    normals: np.ndarray
    tree: cKDTree
    centre: np.ndarray
    radius_mm: float
    lo: np.ndarray | None = None
    hi: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.lo is None or self.hi is None:
            self.lo, self.hi = self.points.min(axis=0), self.points.max(axis=0)

    def signed_distance(self, Y: np.ndarray, k: int = 8, inside_share: float = 0.75) -> tuple[np.ndarray, np.ndarray]:
        """Point-to-plane signed distance (mm, negative inside) of points Y (M, 3) in the model
        frame at the nearest sample, and the normals (M, 3) it was measured along.

        A point counts as inside only when at least ``inside_share`` of its ``k`` nearest samples'
        planes have it behind them; otherwise a negative distance is set to 0 (on the surface).
        The nearest sample's plane alone misjudges points off a convex edge with an overhang (the
        rim of the potted meat can's lid faces down: a box standing 20 mm beside and above it read
        4 mm inside)."""
        Y = np.asarray(Y, np.float64).reshape(-1, 3)
        _, i0 = self.tree.query(Y)
        n = self.normals[i0]
        d = np.einsum("ij,ij->i", Y - self.points[i0], n)
        neg = np.flatnonzero(d < 0)          # the vote only where the nearest plane says inside
        if len(neg):
            _, idx = self.tree.query(Y[neg], k=k)
            idx = idx.reshape(len(neg), -1)
            dk = np.einsum("mkj,mkj->mk", Y[neg][:, None, :] - self.points[idx], self.normals[idx])
            d[neg[(dk < 0).mean(axis=1) < inside_share]] = 0.0
        return d, n

    def penetration_depth(self, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(depth inside (M,) mm, >= 0, 0 outside; normals (M, 3)) of points Y (M, 3) in the model
        frame: -:meth:`signed_distance` where that is negative. Points outside the samples'
        axis-aligned box cannot be inside the surface and are not looked up (most of the points a
        :class:`ContactGroup` holds, which reach the other object's bounding sphere plus a
        margin): depth 0, normal 0."""
        Y = np.asarray(Y, np.float64).reshape(-1, 3)
        p = np.zeros(len(Y))
        n = np.zeros((len(Y), 3))
        q = np.flatnonzero(np.all((Y >= self.lo) & (Y <= self.hi), axis=1))
        if len(q):
            dq, n[q] = self.signed_distance(Y[q])
            p[q] = np.maximum(-dq, 0.0)
        return p, n


_SURFACES: dict[int, tuple[object, ContactSurface]] = {}


def contact_surface(mesh, n_samples: int = 20000, seed: int = 0) -> ContactSurface:
    """The :class:`ContactSurface` of a ``trimesh.Trimesh`` (mm): ``n_samples`` area-uniform samples
    with their faces' normals (deterministic for a given ``seed``). Cached per mesh object."""
    hit = _SURFACES.get(id(mesh))
    if hit is not None and hit[0] is mesh:
        return hit[1]
    import trimesh

    P, fi = trimesh.sample.sample_surface(mesh, n_samples, seed=seed)
    P = np.asarray(P, np.float64)
    N = np.asarray(mesh.face_normals[fi], np.float64)
    c = 0.5 * (P.min(0) + P.max(0))
    surf = ContactSurface(P, N, cKDTree(P), c, float(np.linalg.norm(P - c, axis=1).max()))
    _SURFACES[id(mesh)] = (mesh, surf)
    return surf


@dataclass
class ContactGroup:
    j: int          # object whose points are tested
    other: int      # object they must stay out of
    X: np.ndarray   # (N, 3) model points of j (mm)


@dataclass
class ContactTerm:
    """f_contact over ordered pairs (j, k) of nearby objects (see module doc)."""

    surfaces: list[ContactSurface]
    groups: list[ContactGroup] = field(default_factory=list)
    weight: float = 1.0
    tol_mm: float = 1.0
    name: str = "contact"

    def n_obs(self) -> int:
        """A constraint, not an observation: it adds nothing to the residual's degrees of freedom."""
        return 0

    def _penetration(self, pb: BundleProblem, gr: ContactGroup) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(p - tol_mm (N,), world points W (N, 3), world normals n_w (N, 3))."""
        Tj, Tk = pb.T_m[gr.j], pb.T_m[gr.other]
        W = gr.X @ Tj[:3, :3].T + Tj[:3, 3]
        Y = (W - Tk[:3, 3]) @ Tk[:3, :3]                 # R_k^T (W - t_k)
        p, n = self.surfaces[gr.other].penetration_depth(Y)
        return p - self.tol_mm, W, n @ Tk[:3, :3].T

    def cost(self, pb: BundleProblem) -> float:
        tot = 0.0
        for gr in self.groups:
            r = np.maximum(self._penetration(pb, gr)[0], 0.0)
            tot += float(np.dot(r, r))
        return self.weight * tot

    def linearize(self, pb: BundleProblem) -> tuple[float, list[Linearization]]:
        total, out = 0.0, []
        for gr in self.groups:
            r, W, n_w = self._penetration(pb, gr)
            ok = r > 0.0
            if not ok.any():
                continue
            r, W, n_w = r[ok], W[ok], n_w[ok]
            total += float(np.dot(r, r))
            m = len(r)
            M = np.zeros((m, 2, 3))
            M[:, 0, :] = -n_w                                   # d p / d W
            Jj = _se3_jac(M, W, np.empty((m, 2, 6)))
            Jk = -Jj
            A = np.zeros((m, 2, 2))
            A[:, 0, 0] = 2.0 * self.weight
            g = np.zeros((m, 2))
            g[:, 0] = 2.0 * self.weight * r                      # d f / d p
            out.append(Linearization(int(pb.obj_block[gr.j]), int(pb.obj_block[gr.other]), Jj, Jk, A, g))
        return self.weight * total, out


def contact_groups(pb: BundleProblem, surfaces: list[ContactSurface], points: list[np.ndarray],
                   margin_mm: float = 30.0) -> list[ContactGroup]:
    """Ordered pairs (j, k) of known objects whose bounding spheres come within ``margin_mm`` of
    each other at the current poses, each with those of j's ``points`` (model frame, mm) that lie
    within k's bounding sphere plus ``margin_mm`` (the points that can reach into k during the
    next solve). Pairs in which neither object is free are left out."""
    known = getattr(pb, "obj_known", np.ones(len(pb.obj_ids), bool))
    centres = [pb.T_m[j][:3, :3] @ s.centre + pb.T_m[j][:3, 3] for j, s in enumerate(surfaces)]
    out = []
    for j in range(len(surfaces)):
        for k in range(len(surfaces)):
            if j == k or not (known[j] and known[k]) or not (pb.obj_free[j] or pb.obj_free[k]):
                continue
            reach = surfaces[k].radius_mm + margin_mm
            if np.linalg.norm(centres[j] - centres[k]) > surfaces[j].radius_mm + reach:
                continue
            W = points[j] @ pb.T_m[j][:3, :3].T + pb.T_m[j][:3, 3]
            near = np.linalg.norm(W - centres[k], axis=1) < reach
            if near.any():
                out.append(ContactGroup(j, k, points[j][near]))
    return out
