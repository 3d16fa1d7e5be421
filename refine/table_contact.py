"""Objects standing on the table share its plane (``RefineOptions.table_contact``).

With a 20-degree viewing baseline the objects of a bundle can turn together about the scene,
relative to every camera, at almost no cost in the images: each object's depth changes with
its lateral place in the scene, its lateral image position hardly at all. Measured on the suite's
medium-3 from the exact GT (session 47, ``bench/results/ycbv21/README.md``): the refined objects
are turned 0.18 deg together about the scene centre in every view (a rigid fit of their centres
to the GT takes the rms error 0.92 -> 0.64 mm); that turn tilts the plane they stand on by
0.12 deg. The table's own texture measures that plane's normal in camera coordinates, whatever
the scene's scale: a plane's homography between two views is H = R + t n^T
(:func:`refine.table.table_rotation`, ``with_normal``; at the exact GT of medium-3 within
0.017-0.061 deg of the objects' support plane).

So every object whose lowest point touches the support plane is held at the same height above a
plane of the measured normal:

    f_table_contact = weight * sum_{j<l} (h_j - h_l)^2 / (m sigma^2),   h_j = min_p n . (R_j X_p + t_j)

over the m touching objects (X_p: the model's convex-hull vertices, mm; n: the measured unit
normal in the world, pointing to the cameras). Only differences of heights enter, so the common
height -- the table's distance, i.e. the scene's scale -- stays free; pairs of objects make each
residual touch two blocks, as the solver's linearisations require (the sum over pairs is m times
the sum of squared deviations from the mean height). The lowest point is piecewise smooth in the
pose: its Jacobian is that of the current lowest vertex (left increments, world frame:
dh/dv = n, dh/dw = W x n).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .problem import BundleProblem


def lowest_point(T: np.ndarray, X_mm: np.ndarray, n: np.ndarray) -> tuple[float, np.ndarray]:
    """(height n . W (mm), W (3,)) of the lowest of the points ``X_mm`` (model frame) at pose ``T``
    along the unit normal ``n`` (world frame)."""
    W = X_mm @ T[:3, :3].T + T[:3, 3]
    h = W @ n
    k = int(np.argmin(h))
    return float(h[k]), W[k]


def mean_normal(normals: list[np.ndarray], covs: list[np.ndarray], up: np.ndarray) -> np.ndarray | None:
    """Unit normal from several measurements (3,) with covariances (3, 3), each weighted by the
    inverse of its covariance's trace and turned to the side of ``up``; None without any."""
    acc = np.zeros(3)
    for n, c in zip(normals, covs):
        tr = float(np.trace(c))
        if not (np.all(np.isfinite(n)) and np.isfinite(tr) and tr > 0):
            continue
        acc += (n if n @ up >= 0 else -n) / tr
    norm = float(np.linalg.norm(acc))
    return acc / norm if norm > 0 else None


def normal_sigma_deg(covs: list[np.ndarray]) -> float:
    """Angular 1-sigma (deg) of the inverse-trace-weighted mean of normals with covariances
    ``covs`` (3, 3; rad^2) taken as independent: sqrt(1 / sum 1/trace); inf without a usable one."""
    inv = [1.0 / float(np.trace(c)) for c in covs if np.isfinite(np.trace(c)) and float(np.trace(c)) > 0]
    return float(np.degrees(np.sqrt(1.0 / sum(inv)))) if inv else float("inf")


def stacked_gap(T_j: np.ndarray, X_j: np.ndarray, T_k: np.ndarray, surface_k, n: np.ndarray
                ) -> tuple[float, np.ndarray, np.ndarray]:
    """How far (mm) the lowest of object j's hull points ``X_j`` along the unit normal ``n`` (world)
    lies above object k's surface (``surface_k``: a :class:`refine.contact.ContactSurface`, model
    frame of k), measured point-to-plane at k's nearest surface sample (negative: inside k): the
    gap, the lowest point W (3,) and k's surface normal there (3,), both in the world."""
    _, W = lowest_point(T_j, X_j, n)
    Y = (W - T_k[:3, 3]) @ T_k[:3, :3]
    d, nk = surface_k.signed_distance(Y[None])
    return float(d[0]), W, T_k[:3, :3] @ nk[0]


@dataclass
class TableContactTerm:
    """The touching objects' lowest points held to one plane of the measured normal (module
    docstring). ``groups``: (object index j, convex-hull vertices (N, 3) mm, model frame).
    ``stacked``: (j, its hull vertices, k, k's :class:`refine.contact.ContactSurface`) for an object
    j standing on object k instead of the table (``RefineOptions.stack_rest``): the gap of
    :func:`stacked_gap` is held to 0 (two-sided, same sigma), so j neither sinks into k nor lifts
    off it along its line of sight when its contour on k is left out of f_edge."""

    normal_w: np.ndarray
    groups: list = field(default_factory=list)
    sigma_mm: float = 0.5
    weight: float = 1.0
    name: str = "table_contact"
    stacked: list = field(default_factory=list)

    def n_obs(self) -> int:
        return max(len(self.groups) - 1, 0) + len(self.stacked)

    def _stacked_gaps(self, pb: BundleProblem) -> list[tuple[int, int, float, np.ndarray, np.ndarray]]:
        out = []
        for j, X, k, surf in self.stacked:
            if np.all(np.isfinite(pb.T_m[j])) and np.all(np.isfinite(pb.T_m[k])):
                gap, W, nk = stacked_gap(pb.T_m[j], X, pb.T_m[k], surf, self.normal_w)
                out.append((j, k, gap, W, nk))
        return out

    def _heights(self, pb: BundleProblem) -> list[tuple[int, float, np.ndarray]]:
        """(object index, lowest height, lowest point) of the objects whose pose is finite: a pose
        that turned non-finite is failed elsewhere and must not reach the others through this term."""
        out = []
        for j, X in self.groups:
            if np.all(np.isfinite(pb.T_m[j])):
                h, W = lowest_point(pb.T_m[j], X, self.normal_w)
                out.append((j, h, W))
        return out

    def cost(self, pb: BundleProblem) -> float:
        hs = np.array([h for _, h, _ in self._heights(pb)])
        m = len(hs)
        c = self.weight * float(m * np.sum((hs - hs.mean()) ** 2)) / (m * self.sigma_mm ** 2) if m >= 2 else 0.0
        for _, _, gap, _, _ in self._stacked_gaps(pb):
            c += self.weight * (gap / self.sigma_mm) ** 2
        return c

    def linearize(self, pb: BundleProblem) -> tuple[float, list]:
        from .terms import Linearization
        low = self._heights(pb)
        m = len(low)
        out, total = [], 0.0
        for j, k, gap, W, nk in self._stacked_gaps(pb):
            e = gap / self.sigma_mm
            total += e * e
            Ja = np.zeros((1, 2, 6))
            Ja[0, 0] = np.r_[nk, np.cross(W, nk)] / self.sigma_mm     # the point moves with j ...
            A = np.zeros((1, 2, 2))
            A[0, 0, 0] = 2.0 * self.weight
            g = np.array([[2.0 * self.weight * e, 0.0]])
            out.append(Linearization(int(pb.obj_block[j]), int(pb.obj_block[k]), Ja, -Ja, A, g))  # ... k's surface with k
        if m < 2:
            return self.weight * total, out
        s = self.sigma_mm * np.sqrt(m)
        n = self.normal_w
        jac = [np.r_[n, np.cross(W, n)] / s for _, _, W in low]
        for a in range(m):
            for b in range(a + 1, m):
                e = (low[a][1] - low[b][1]) / s
                total += e * e
                Ja, Jb = np.zeros((1, 2, 6)), np.zeros((1, 2, 6))
                Ja[0, 0], Jb[0, 0] = jac[a], -jac[b]
                A = np.zeros((1, 2, 2))
                A[0, 0, 0] = 2.0 * self.weight
                g = np.array([[2.0 * self.weight * e, 0.0]])
                out.append(Linearization(int(pb.obj_block[low[a][0]]), int(pb.obj_block[low[b][0]]), Ja, Jb, A, g))
        return self.weight * total, out
