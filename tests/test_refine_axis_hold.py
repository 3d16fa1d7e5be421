"""refine.axis_hold: the turn about a model axis, and the term's gradient against its cost."""
from __future__ import annotations

import numpy as np

from ycbvss.geometry.so3 import exp_so3
from ycbvss.refine.axis_hold import AxisHoldTerm, axis_turn_rad


def test_turn_about_the_axis_is_measured_and_other_turns_are_not():
    rng = np.random.default_rng(3)
    R0 = exp_so3(rng.normal(size=3))
    a = np.array([0.0, 1.0, 0.0])
    assert abs(axis_turn_rad(R0, R0 @ exp_so3(0.3 * a), a) - 0.3) < 1e-12
    # a turn about an axis at right angles to it is no turn about it
    assert abs(axis_turn_rad(R0, R0 @ exp_so3(np.array([0.2, 0.0, 0.0])), a)) < 1e-12
    # expressed in the world frame the same turn is R0 a
    assert abs(axis_turn_rad(R0, exp_so3(0.1 * (R0 @ a)) @ R0, a) - 0.1) < 1e-12


class _Pb:
    """The two fields of BundleProblem the term reads."""

    def __init__(self, T_m):
        self.T_m = T_m
        self.obj_block = np.array([0, -1])


def test_gradient_matches_the_cost_under_left_world_increments():
    rng = np.random.default_rng(7)
    R0 = exp_so3(rng.normal(size=3))
    a = np.array([0.0, 0.0, 1.0])
    T = np.eye(4)
    T[:3, :3] = exp_so3(np.array([0.01, -0.02, 0.03])) @ R0
    T[:3, 3] = [10.0, -5.0, 800.0]
    term = AxisHoldTerm([(0, a, R0)], sigma_rad=1e-2)
    pb = _Pb(np.stack([T, np.eye(4)]))
    f0, lins = term.linearize(pb)
    assert abs(f0 - term.cost(pb)) < 1e-9 and len(lins) == 1 and lins[0].a == 0 and lins[0].b == -1
    L = lins[0]
    grad = L.Ja[0].T @ L.g[0]                        # d f / d (v, w), 6-vector
    eps = 1e-6
    for k in range(6):
        d = np.zeros(6)
        d[k] = eps
        Tp = T.copy()
        Tp[:3, :3] = exp_so3(d[3:]) @ T[:3, :3]
        Tp[:3, 3] = exp_so3(d[3:]) @ T[:3, 3] + d[:3]
        num = (term.cost(_Pb(np.stack([Tp, np.eye(4)]))) - f0) / eps
        assert abs(num - grad[k]) <= 1e-3 * max(1.0, abs(grad[k])), (k, num, grad[k])
    # translation is free
    assert np.allclose(grad[:3], 0.0)
