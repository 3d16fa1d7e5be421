"""Hold a rotationally symmetric object's turn about its own axis (``RefineOptions.axis_hold``).

A textured object whose shape is (nearly) rotationally symmetric -- a can, the large marker --
shows the same silhouette whatever its turn about its axis; only its texture fixes that turn. At
the coarse blur levels, while its position is still off, the interior texture samples are
matched to edges a few pixels away, and turning the object about its axis moves them sideways
at no contour cost: the optimiser spends the turn on a lateral error and keeps it (the ycbv21-fresh
short-35 marker, found there: 24 deg at the 4 px level, 47 more at the 2 px level, 54 deg in
the end, flagged by the texture check). This term holds that one degree of freedom at the pose
the level started from, with a stiff quadratic,

    f_axis = weight * (phi / sigma_rad)^2,   phi = a . log(R_0^T R)   (rad),

``a`` the unit symmetry axis in the model frame, ``R_0`` the orientation at the start of the level
and ``R`` the current one (model to world). With left increments in world coordinates
(R <- exp(w) R) R_0^T exp(w) R = D exp(R^T w) with D = R_0^T R, so d phi / d w = a^T J_r^-1(log D) R^T
(J_r the right Jacobian of SO(3)); the translation is left free.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geometry.so3 import hat, log_so3
from .problem import BundleProblem


def right_jacobian_inv(xi: np.ndarray) -> np.ndarray:
    """J_r^-1 (3, 3) of SO(3) at the rotation vector ``xi`` (rad): log(exp(xi) exp(d)) = xi + J_r^-1 d + O(d^2)."""
    th = float(np.linalg.norm(xi))
    X = hat(xi)
    if th < 1e-6:
        return np.eye(3) + 0.5 * X + X @ X / 12.0
    c = 1.0 / th ** 2 - (1.0 + np.cos(th)) / (2.0 * th * np.sin(th))
    return np.eye(3) + 0.5 * X + c * (X @ X)


def axis_turn_rad(R0: np.ndarray, R: np.ndarray, axis_model: np.ndarray) -> float:
    """The turn (rad) of orientation ``R`` from ``R0`` (3x3, model to world) about the model-frame
    unit axis ``axis_model``: the component of the model-frame rotation vector log(R0^T R) along it."""
    return float(np.asarray(log_so3(R0.T @ R), np.float64) @ axis_model)


@dataclass
class AxisHoldTerm:
    """``groups``, per held object: (object index j, model-frame unit axis (3,), start orientation (3, 3))."""

    groups: list = field(default_factory=list)
    sigma_rad: float = 1e-3
    weight: float = 1.0
    name: str = "axis_hold"

    def n_obs(self) -> int:
        return len(self.groups)

    def _turns(self, pb: BundleProblem) -> list[tuple[int, float, np.ndarray]]:
        out = []
        for j, a, R0 in self.groups:
            R = pb.T_m[j][:3, :3]
            if np.all(np.isfinite(R)):
                xi = np.asarray(log_so3(R0.T @ R), np.float64)
                out.append((j, float(xi @ a), R @ (right_jacobian_inv(xi).T @ a)))    # phi, d phi / d w
        return out

    def cost(self, pb: BundleProblem) -> float:
        return self.weight * float(sum((phi / self.sigma_rad) ** 2 for _, phi, _ in self._turns(pb)))

    def linearize(self, pb: BundleProblem) -> tuple[float, list]:
        from .terms import Linearization
        out, total = [], 0.0
        for j, phi, a_w in self._turns(pb):
            e = phi / self.sigma_rad
            total += e * e
            J = np.zeros((1, 2, 6))
            J[0, 0, 3:] = a_w / self.sigma_rad
            A = np.zeros((1, 2, 2))
            A[0, 0, 0] = 2.0 * self.weight
            g = np.array([[2.0 * self.weight * e, 0.0]])
            out.append(Linearization(int(pb.obj_block[j]), -1, J, np.zeros((1, 2, 6)), A, g))
        return self.weight * total, out
