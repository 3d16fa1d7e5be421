"""SO(3)/SE(3) and pinhole camera: exact round trips and hand-computed cases."""
import numpy as np
import pytest

from ycbvss.camera import Camera, backproject, check_K, project
from ycbvss.errors import YcbvssError
from ycbvss.geometry import (compose, exp_se3, exp_so3, interpolate_T, inv_T, is_rotation, log_se3,
                             log_so3, make_T, perturb_T, project_to_so3, random_rotation,
                             rotation_angle_deg, transform_points, adjoint)

RNG = np.random.default_rng(0)


def test_exp_log_so3_round_trip_including_small_and_near_pi():
    w = RNG.normal(size=(500, 3))
    w = w / np.linalg.norm(w, axis=1, keepdims=True) * RNG.uniform(0, np.pi - 1e-3, (500, 1))
    w[:5] *= 1e-9                                   # tiny angles
    R = exp_so3(w)
    assert np.max(np.abs(log_so3(R) - w)) < 1e-8
    # near pi: the rotation (not the vector's sign) must round-trip
    a = np.array([0.3, -0.5, 0.81]); a /= np.linalg.norm(a)
    for th in (np.pi - 1e-7, np.pi - 1e-4, np.pi):
        R = exp_so3(a * th)
        assert np.max(np.abs(exp_so3(log_so3(R)) - R)) < 1e-6


def test_rotation_angle_hand_case():
    R = exp_so3(np.array([0.0, 0.0, np.radians(30.0)]))
    assert rotation_angle_deg(R) == pytest.approx(30.0, abs=1e-9)
    assert R[0, 1] == pytest.approx(-0.5, abs=1e-12)   # Rz(30) row 0: cos, -sin, 0


def test_is_rotation_and_projection():
    R = random_rotation(RNG, 10)
    assert np.all(is_rotation(R))
    noisy = R + 1e-3 * RNG.normal(size=R.shape)
    assert not np.any(is_rotation(noisy))
    assert np.all(is_rotation(project_to_so3(noisy)))
    assert not is_rotation(np.diag([1.0, 1.0, -1.0]))       # reflection
    assert not is_rotation(np.full((3, 3), np.nan))


def test_se3_exp_log_inverse_compose():
    xi = np.concatenate([RNG.normal(scale=100, size=(50, 3)), RNG.normal(scale=0.8, size=(50, 3))], 1)
    T = exp_se3(xi)
    assert np.max(np.abs(log_se3(T) - xi)) < 1e-7
    assert np.max(np.abs(compose(T, inv_T(T)) - np.eye(4))) < 1e-10
    X = RNG.normal(size=(20, 3))
    Y = transform_points(T[0], X)
    assert np.max(np.abs(transform_points(inv_T(T[0]), Y) - X)) < 1e-9
    # adjoint identity: T exp(xi) T^-1 = exp(Ad_T xi)
    d = np.array([1.0, -2.0, 0.5, 0.01, 0.02, -0.03])
    lhs = T[1] @ exp_se3(d) @ inv_T(T[1])
    assert np.max(np.abs(lhs - exp_se3(adjoint(T[1]) @ d))) < 1e-9


def test_interpolation_endpoints_and_midpoint():
    T0 = make_T(np.eye(3), [0, 0, 500])
    T1 = make_T(exp_so3(np.array([0, np.radians(40), 0])), [100, 0, 600])
    S = interpolate_T(T0, T1, np.array([0.0, 0.5, 1.0]))
    assert np.allclose(S[0], T0) and np.allclose(S[2], T1)
    assert rotation_angle_deg(S[1][:3, :3]) == pytest.approx(20.0, abs=1e-9)
    assert np.allclose(S[1][:3, 3], [50, 0, 550])


def test_perturb_statistics():
    T = np.repeat(make_T(np.eye(3), [0, 0, 800])[None], 20000, 0)
    P = perturb_T(T, t_sigma=5.0, r_sigma_deg=2.0, rng=np.random.default_rng(1))
    dt = P[:, :3, 3] - T[:, :3, 3]
    assert np.std(dt) == pytest.approx(5.0, rel=0.03)
    # angle of a 3D isotropic normal rotation vector: mean = sigma * sqrt(8/pi)
    assert np.mean(rotation_angle_deg(P[:, :3, :3])) == pytest.approx(2.0 * np.sqrt(8 / np.pi), rel=0.03)


def test_camera_projection_round_trip_and_hand_case():
    K = np.array([[1066.778, 0, 312.9869], [0, 1067.487, 241.3109], [0, 0, 1]])
    cam = Camera(K, 640, 480)
    uv = cam.project(np.array([100.0, -50.0, 1000.0]))
    assert uv == pytest.approx([312.9869 + 106.6778, 241.3109 - 53.37435], abs=1e-9)
    X = RNG.uniform([-300, -200, 400], [300, 200, 1500], size=(100, 3))
    assert np.max(np.abs(backproject(K, project(K, X), X[:, 2]) - X)) < 1e-9
    half = cam.scaled(0.5)
    assert half.width == 320 and half.fx == pytest.approx(K[0, 0] / 2)


@pytest.mark.parametrize("K", [np.eye(2), np.zeros((3, 3)), np.array([[1, 0, 0], [0, np.nan, 0], [0, 0, 1.0]])])
def test_bad_K_raises_clear_error(K):
    with pytest.raises(YcbvssError, match="K"):
        check_K(K, "scene_camera.json", "scene 1 frame 2")
