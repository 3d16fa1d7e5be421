"""The bundle problem: views (cameras), objects and their parameter blocks.

World frame = the first view's camera frame (by default its camera is fixed to identity, the
gauge; the refiner's keyframe bundle re-fits it after each solve and moves the world back to it,
see ``RefineOptions.register_gauge`` and ``free_gauge``).
The pose of object j in view i is P_ij = T_c[i] @ T_m[j] (object-to-camera, mm).
Parameters are left se(3) increments: camera blocks for views 1..n-1 (those marked free), then
object blocks for all objects (those marked free).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geometry.se3 import exp_se3, inv_T


@dataclass
class View:
    """One image of the bundle: id, intrinsics, size, image (HxWx3 uint8)."""

    im_id: int
    K: np.ndarray
    width: int
    height: int
    image: np.ndarray | None = None


@dataclass
class BundleProblem:
    """Poses to refine. ``T_c`` (n, 4, 4) world-to-camera, ``T_m`` (m, 4, 4) model-to-world (mm)."""

    views: list[View]
    obj_ids: list[int]
    T_c: np.ndarray
    T_m: np.ndarray
    cam_free: np.ndarray = field(default=None)    # (n,) bool; default: all but view 0
    obj_free: np.ndarray = field(default=None)    # (m,) bool
    # per object: (centroid (3,) mm, covariance (3, 3) mm^2) of its model points in the model frame;
    # when set, the solver's ridge on an object block is measured by how far a step moves the
    # object's points (:meth:`object_ridges`), not in the world-origin se(3) coordinates
    obj_moments: list | None = field(default=None)

    def __post_init__(self):
        n, m = len(self.views), len(self.obj_ids)
        self.T_c = np.array(self.T_c, dtype=np.float64).reshape(n, 4, 4)
        self.T_m = np.array(self.T_m, dtype=np.float64).reshape(m, 4, 4)
        if self.cam_free is None:
            self.cam_free = np.ones(n, dtype=bool)
            self.cam_free[0] = False
        if self.obj_free is None:
            self.obj_free = np.ones(m, dtype=bool)
        self.cam_free = np.asarray(self.cam_free, dtype=bool).copy()
        self.obj_free = np.asarray(self.obj_free, dtype=bool).copy()
        self._index()

    def _index(self) -> None:
        """Block index per camera / object (-1 = fixed)."""
        k = 0
        self.cam_block = -np.ones(len(self.views), dtype=int)
        for i, f in enumerate(self.cam_free):
            if f:
                self.cam_block[i] = k
                k += 1
        self.obj_block = -np.ones(len(self.obj_ids), dtype=int)
        for j, f in enumerate(self.obj_free):
            if f:
                self.obj_block[j] = k
                k += 1
        self.n_blocks = k

    @property
    def n_params(self) -> int:
        return 6 * self.n_blocks

    def pose(self, i: int, j: int) -> np.ndarray:
        """Object-to-camera pose P_ij = T_c[i] T_m[j]."""
        return self.T_c[i] @ self.T_m[j]

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.T_c.copy(), self.T_m.copy()

    def set_state(self, st: tuple[np.ndarray, np.ndarray]) -> None:
        self.T_c, self.T_m = st[0].copy(), st[1].copy()

    def apply_step(self, delta: np.ndarray) -> None:
        """Left-multiply every free block by exp(delta_block)."""
        delta = np.asarray(delta, dtype=np.float64).reshape(-1, 6)
        for i, b in enumerate(self.cam_block):
            if b >= 0:
                self.T_c[i] = exp_se3(delta[b]) @ self.T_c[i]
        for j, b in enumerate(self.obj_block):
            if b >= 0:
                self.T_m[j] = exp_se3(delta[b]) @ self.T_m[j]

    def object_ridges(self) -> list[tuple[int, np.ndarray]]:
        """Per free object block b: Q (6, 6) with delta^T Q delta = the mean squared displacement
        (mm^2) of the object's model points under the left increment delta = (v, w) of its block
        (first order: a world point X moves by v + w x X). With c, C the points' centroid and
        covariance in the world: |v + w x c|^2 + w^T (tr(C) I - C) w. A translation is charged by
        its length, a turn by what it moves the object's points -- independent of how far the
        object is from the world origin (the first camera). Empty without ``obj_moments``; an
        object whose entry is None keeps the solver's eps * I ridge."""
        if self.obj_moments is None:
            return []
        out = []
        for j, b in enumerate(self.obj_block):
            if b < 0 or self.obj_moments[j] is None:
                continue
            c_m, C_m = self.obj_moments[j]
            R, t = self.T_m[j][:3, :3], self.T_m[j][:3, 3]
            c, C = R @ c_m + t, R @ C_m @ R.T
            A = np.hstack([np.eye(3), -_hat(c)])          # centroid displacement v + w x c = A delta
            Q = A.T @ A
            Q[3:, 3:] += np.trace(C) * np.eye(3) - C
            out.append((int(b), Q))
        return out

    def camera_centre(self, i: int) -> np.ndarray:
        return inv_T(self.T_c[i])[:3, 3]


def _hat(c: np.ndarray) -> np.ndarray:
    """Cross-product matrix: _hat(c) @ w = c x w."""
    return np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])


def model_moments(points_mm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(centroid (3,), covariance (3, 3)) of model points (N, 3) mm, for ``obj_moments``."""
    P = np.asarray(points_mm, np.float64)
    c = P.mean(0)
    return c, np.cov((P - c).T, bias=True)
