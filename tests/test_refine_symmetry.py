"""Symmetric objects in the scene-consistent initialisation (ycbvss.refine.init).

Regression: a can (continuous symmetry about z + a flip) whose per-view inits are ~2 cm off in
depth was turned by 10-20 deg about its axis by the symmetric alignment (it chose the equivalent
with the smallest mean 3D point distance, which an unevenly sampled mesh biases); the edge term
cannot undo such a turn, so YCBV-SS video 0001 ended at R 20 deg / PRJ 10 px for 002_master_chef_can.
Budget: < 2 s."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ycbvss.geometry.se3 import make_T
from ycbvss.geometry.so3 import exp_so3, log_so3, rotation_angle_deg
from ycbvss.geometry.symmetry import symmetry_transforms
from ycbvss.refine.init import align_symmetric, initialise
from ycbvss.refine.problem import View

FLIP = [1, 0, 0, 0, 0, -1, 0, 0, 0, 0, -1, 0, 0, 0, 0, 1]


def _can():
    model = SimpleNamespace(symmetries_discrete=[FLIP],
                            symmetries_continuous=[{"axis": [0, 0, 1], "offset": [0, 0, 0]}])
    rng = np.random.default_rng(0)
    # an unevenly sampled can surface (r 50 mm, h 140 mm): most samples on one side, as real meshes
    # with detailed labels have
    phi = np.concatenate([rng.uniform(0, 2 * np.pi, 60), rng.normal(0.6, 0.3, 140)])
    z = rng.uniform(-70, 70, len(phi))
    X = np.stack([50 * np.cos(phi), 50 * np.sin(phi), z], 1)
    return model, X


def _views(n):
    K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])
    return [View(i, K, 640, 480, np.zeros((480, 640, 3), np.uint8)) for i in range(n)]


def _gt_and_obs(n, rng):
    R0 = exp_so3(np.array([1.9, 0.2, 0.3]))
    gt, obs = {}, {}
    for i in range(n):     # a camera moving a few mm (as in the YCB-V clips)
        G = make_T(R0, np.array([10.0 + 3 * i, -20.0, 800.0]))
        gt[i] = G
        dR = exp_so3(rng.normal(0, 2.0, 3) * np.pi / 180)
        t = G[:3, 3] + np.array([rng.normal(0, 2), rng.normal(0, 2), 25.0 * rng.choice([-1, 1])])
        obs[(i, 0)] = make_T(dR @ G[:3, :3], t)
    return gt, obs


def test_alignment_keeps_texture_rotation_and_undoes_flips():
    model, X = _can()
    S = symmetry_transforms(model)
    rng = np.random.default_rng(1)
    gt, obs = _gt_and_obs(6, rng)
    T_c = np.tile(np.eye(4), (6, 1, 1))
    T_m = gt[0][None].copy()
    out = align_symmetric(obs, T_c, T_m, [S], [X])
    turn = [rotation_angle_deg(out[(i, 0)][:3, :3].T @ obs[(i, 0)][:3, :3]) for i in range(6)]
    assert max(turn) < 0.5, turn          # small deviations: the observation itself is kept (no turn)
    # an init on the wrong symmetric branch (upside down and turned 100 deg) is mapped back
    bad = {(0, 0): obs[(0, 0)] @ S[1] @ make_T(exp_so3(np.array([0, 0, np.radians(100)])), np.zeros(3))}
    back = align_symmetric(bad, T_c, T_m, [S], [X])[(0, 0)]
    err = rotation_angle_deg(back[:3, :3].T @ gt[0][:3, :3])
    assert err < 5.0 + 2.0 * 3, err        # within half a 10 deg step + the 2 deg/axis deviation


def test_scene_consistent_init_of_a_can_keeps_its_rotation():
    model, X = _can()
    rng = np.random.default_rng(2)
    n = 5
    gt, obs = _gt_and_obs(n, rng)
    box = make_T(exp_so3(np.array([0.3, -1.2, 0.4])), np.array([-120.0, 30.0, 760.0]))
    Xb = rng.uniform(-40, 40, (200, 3))
    for i in range(n):     # a second, asymmetric object fixes the cameras
        obs[(i, 1)] = make_T(exp_so3(rng.normal(0, 1.0, 3) * np.pi / 180) @ box[:3, :3],
                             box[:3, 3] + np.array([3.0 * i, 0, 0]) + rng.normal(0, 2, 3))
    pb, known = initialise(_views(n), 2, obs, [X, Xb], [symmetry_transforms(model), [np.eye(4)]])
    assert known[0]
    r = [rotation_angle_deg(pb.pose(i, 0)[:3, :3].T @ gt[i][:3, :3]) for i in range(n)]
    r_in = [rotation_angle_deg(obs[(i, 0)][:3, :3].T @ gt[i][:3, :3]) for i in range(n)]
    # the consistent pose is about as good as the inputs (2 deg/axis noise), never a symmetric turn
    assert max(r) < max(r_in) + 1.0, (r, r_in)


def test_consensus_roll_follows_the_observations_not_its_start():
    """Per-view estimates ~5 deg off (the paper's initial error) about a continuous symmetry axis
    must not be snapped to the consensus's current roll: with a 1 deg margin every observation more
    than ~3.5 deg off was replaced by the sampled equivalent (5 deg steps) nearest the consensus, so
    the consensus kept the roll of the view it was propagated from. Here view 0 is 6 deg off about
    the axis and the other 39 average about 0: the consensus must land near their mean."""
    model, X = _can()
    S = symmetry_transforms(model)
    rng = np.random.default_rng(4)
    n = 40
    R0 = exp_so3(np.array([1.9, 0.2, 0.3]))
    box = make_T(exp_so3(np.array([0.3, -1.2, 0.4])), np.array([-120.0, 30.0, 760.0]))
    Xb = rng.uniform(-40, 40, (200, 3))
    gt, obs, roll_deg = {}, {}, []
    for i in range(n):
        G = make_T(R0, np.array([10.0 + 3 * i, -20.0, 800.0]))
        gt[i] = G
        roll = 6.0 if i == 0 else rng.normal(0.0, 3.0)
        roll_deg.append(roll)
        dR = exp_so3(rng.normal(0, 2.0, 3) * np.pi / 180)
        # tilt in the camera frame, roll about the can's own axis (model z)
        obs[(i, 0)] = make_T(dR @ G[:3, :3] @ exp_so3(np.radians([0.0, 0.0, roll])),
                             G[:3, 3] + np.array([rng.normal(0, 2), rng.normal(0, 2), rng.normal(0, 15)]))
        Bi = box.copy()
        Bi[:3, 3] += np.array([3.0 * i, 0, 0])
        obs[(i, 1)] = make_T(exp_so3(rng.normal(0, 1.0, 3) * np.pi / 180) @ Bi[:3, :3], Bi[:3, 3] + rng.normal(0, 2, 3))
    pb, known = initialise(_views(n), 2, obs, [X, Xb], [S, [np.eye(4)]])
    # roll of the consensus about the can's axis (model z), per view against the GT, averaged
    rv = [np.degrees(log_so3(gt[i][:3, :3].T @ pb.pose(i, 0)[:3, :3]))[2] for i in range(n)]
    mean_obs = float(np.mean(roll_deg))
    assert abs(float(np.mean(rv)) - mean_obs) < 1.0, (np.mean(rv), mean_obs)
