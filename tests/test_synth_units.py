"""Unit tests of YCBV-SS synthesis parts that need no Blender. Budget: < 10 s."""
from __future__ import annotations

import numpy as np
import pytest

from ycbvss.blender_scripts.camera import blender_camera_params, border_from_bbox
from ycbvss.errors import YcbvssError
from ycbvss.geometry.model_frame import recentre_pose
from ycbvss.synth.colour_fit import (
    apply_colour_transform,
    delta_e2000,
    fit_colour_transfer_mk,
    fit_colour_transform,
    linear_to_srgb,
    srgb_to_linear,
)
from ycbvss.synth.coverage import SCALE_GRID, choose_scale
from ycbvss.synth.frame import validate_pose
from ycbvss.synth.frame_files import FrameFiles, clean_temporaries
from ycbvss.synth.models import transform_symmetries
from ycbvss.synth.noise import NoiseParams, add_sensor_noise


def _blender_project(K, W, H, X):
    """Project with Blender's camera model (sensor fit horizontal, square pixels, world y scaled by fy/fx)
    and return OpenCV pixel coordinates."""
    p = blender_camera_params(K, W, H)
    X = np.asarray(X, float) * [1.0, p["y_scale"], 1.0]
    f_px = p["lens"] * W / p["sensor_width"]
    xb = f_px * X[:, 0] / X[:, 2] + W / 2 - p["shift_x"] * W        # Blender continuous px, origin left
    yb_up = f_px * (-X[:, 1]) / X[:, 2] + H / 2 - p["shift_y"] * W   # from the bottom
    return np.stack([xb - 0.5, (H - yb_up) - 0.5], 1)


def test_blender_camera_reproduces_K():
    K = np.array([[1066.778, 0, 312.9869], [0, 1067.487, 241.3109], [0, 0, 1]])
    X = np.array([[10.0, -20.0, 700.0], [-150.0, 80.0, 900.0], [0.0, 0.0, 500.0]])
    uv_cv = X[:, :2] / X[:, 2:] @ K[:2, :2].T + K[:2, 2]
    err = np.abs(_blender_project(K, 640, 480, X) - uv_cv).max()
    assert err < 1e-9


def test_border_is_normalised_and_padded():
    b = border_from_bbox((100, 50, 200, 150), 640, 480, pad_px=4)
    assert b[0] == pytest.approx(96.5 / 640) and b[1] == pytest.approx(204.5 / 640)
    assert b[2] == pytest.approx(1 - 154.5 / 480) and b[3] == pytest.approx(1 - 46.5 / 480)
    assert border_from_bbox((700, 10, 800, 20), 640, 480) is None


def test_colour_fits_recover_affine_map_and_lower_dE():
    rng = np.random.default_rng(0)
    src = rng.uniform(0.05, 0.6, (5000, 3))
    M = np.array([[1.3, 0.1, 0.0], [0.05, 0.9, 0.02], [0.0, 0.1, 0.7]])
    b = np.array([0.01, -0.02, 0.03])
    dst = src @ M.T + b
    M1, b1 = fit_colour_transform(src, dst)
    assert np.abs(M1 - M).max() < 1e-2 and np.abs(b1 - b).max() < 5e-3
    M2, b2 = fit_colour_transfer_mk(src, dst)
    out = apply_colour_transform(src, M2, b2)
    de0 = delta_e2000(linear_to_srgb(dst), linear_to_srgb(src)).mean()
    de1 = delta_e2000(linear_to_srgb(dst), linear_to_srgb(out)).mean()
    assert de1 < 0.2 * de0


def test_srgb_round_trip():
    x = np.linspace(0, 1, 256, dtype=np.float32)
    assert np.abs(linear_to_srgb(srgb_to_linear(x)) - x).max() < 1e-5


def test_noise_is_signal_dependent_and_seeded():
    p = NoiseParams(shot=1e-3, read=2e-3)
    img = np.zeros((200, 200, 3), np.float32)
    img[:, 100:] = 0.5
    w = np.ones((200, 200), np.float32)
    a = add_sensor_noise(img, w, p, np.random.default_rng(3)) - img
    b = add_sensor_noise(img, w, p, np.random.default_rng(3)) - img
    assert np.array_equal(a, b)
    s_dark, s_bright = a[:, :100].std(), a[:, 100:].std()
    assert s_dark == pytest.approx(2e-3, rel=0.05)
    assert s_bright == pytest.approx(np.sqrt(1e-3 * 0.5 + 4e-6), rel=0.05)


def test_choose_scale_smallest_covering_and_flag():
    total = 1000
    cov = np.array([990, 994, 996, 998, 999, 1000, 1000])
    assert choose_scale(cov, total) == (1.03, 0.996, False)
    s, c, flagged = choose_scale(np.array([900] * 7), total)
    assert s == SCALE_GRID[-1] and flagged and c == pytest.approx(0.9)


def test_recentre_and_symmetries_consistent():
    rng = np.random.default_rng(1)
    from ycbvss.geometry.so3 import random_rotation
    T = np.eye(4)
    T[:3, :3] = random_rotation(rng)
    T[:3, 3] = [10, 20, 700]
    c = np.array([5.0, -3.0, 40.0])
    X = rng.normal(size=(10, 3)) * 30
    Tc = recentre_pose(T, c)
    cam1 = X @ T[:3, :3].T + T[:3, 3]
    cam2 = (X - c) @ Tc[:3, :3].T + Tc[:3, 3]
    assert np.abs(cam1 - cam2).max() < 1e-9
    S = np.eye(4)
    S[:3, :3] = np.diag([-1, -1, 1])
    S[:3, 3] = [0, 0, 2]
    d, _ = transform_symmetries([S], [], c, 1.03)
    Y = X @ S[:3, :3].T + S[:3, 3]                        # symmetric copy in the input frame
    Yc = ((X - c) * 1.03) @ d[0][:3, :3].T + d[0][:3, 3]  # same in the recentred, scaled frame
    assert np.abs((Y - c) * 1.03 - Yc).max() < 1e-9


def test_validate_pose_nan_and_behind():
    corners = np.array([[x, y, z] for x in (-50, 50) for y in (-50, 50) for z in (-50, 50)], float)
    T = np.eye(4)
    T[2, 3] = 500
    assert validate_pose(T, corners) is None
    T2 = T.copy()
    T2[0, 0] = np.nan
    assert "NaN" in validate_pose(T2, corners)
    T3 = T.copy()
    T3[2, 3] = 20
    assert "behind" in validate_pose(T3, corners)


def test_frame_files_all_or_nothing(tmp_path, monkeypatch):
    f = FrameFiles("scene 0 frame 1")
    f.png(tmp_path / "rgb" / "000001.png", np.zeros((4, 4, 3), np.uint8))
    f.png(tmp_path / "depth" / "000001.png", np.zeros((4, 4), np.uint16))
    import ycbvss.synth.frame_files as ff

    def boom(*a, **k):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(ff, "write_json_atomic", boom)
    with pytest.raises(YcbvssError, match="disk full"):
        f.commit(tmp_path / ".done" / "000001.json", {})
    left = [p for p in tmp_path.rglob("*") if p.is_file()]
    assert len(left) == 0
    (tmp_path / "x").mkdir()
    (tmp_path / "x" / ".tmp-a-1.png").write_bytes(b"1")
    assert clean_temporaries(tmp_path) == 1


class _NoBlender:
    cache: dict = {}
    settings: dict = {}


def test_corrupt_frame_is_skipped_and_recorded(tmp_path):
    from ycbvss.synth.frame import marker_path, process_frame
    bad = tmp_path / "bad.png"
    bad.write_bytes(b"not a png")
    task = {"scene_id": 3, "im_id": 7, "rgb_path": str(bad), "depth_path": None, "label_path": None,
            "K": np.eye(3).tolist(), "depth_scale": 1.0, "objects": []}
    m = process_frame(_NoBlender(), {"split_dir": str(tmp_path / "test"), "meshes": {}, "seed": 0,
                                     "render": {}}, task)
    assert "corrupt" in m["skipped"]
    assert marker_path(tmp_path / "test", 3, 7).is_file()
    assert not (tmp_path / "test" / "000003" / "rgb").exists()


def test_unwritable_output_is_a_clear_error(tmp_path, ycbv_root):
    from ycbvss.synth.run import run_synth
    blocker = tmp_path / "file"
    blocker.write_text("x")
    with pytest.raises(YcbvssError, match="not writable"):
        run_synth(ycbv_root, "test", blocker / "out", scenes=[0])


def test_bop_input_with_nan_pose_skips_only_that_frame(tmp_path):
    import json

    from ycbvss.scene import ObjectModel
    from ycbvss.synth.inputs import load_bop_scene_tolerant
    sdir = tmp_path / "test" / "000004"
    sdir.mkdir(parents=True)
    cam = {"cam_K": [600, 0, 320, 0, 600, 240, 0, 0, 1], "depth_scale": 0.1}
    (sdir / "scene_camera.json").write_text(json.dumps({"1": cam, "2": cam, "3": cam}))
    good = {"cam_R_m2c": [1, 0, 0, 0, 1, 0, 0, 0, 1], "cam_t_m2c": [0, 0, 700], "obj_id": 5}
    nan = {**good, "cam_t_m2c": [0, float("nan"), 700]}
    behind = {**good, "cam_t_m2c": [0, 0, -50]}
    (sdir / "scene_gt.json").write_text(json.dumps({"1": [good], "2": [good, nan], "3": [behind]}))
    scene, skipped = load_bop_scene_tolerant(tmp_path / "test", 4, {5: ObjectModel(5)})
    assert [f.im_id for f in scene.frames] == [1]
    assert [i for i, _ in skipped] == [2, 3]
    assert "NaN" in skipped[0][1] and "behind" in skipped[1][1]


def test_clear_objects_removes_a_misannotated_rim():
    """A real object 3 px wider than its annotation leaves a rim outside the render; in-painting the
    objects (+4 px) from the background must remove it (rim colour distance to background < 10 %)."""
    from ycbvss.synth.composite import clear_objects
    H, W = 80, 100
    img = np.full((H, W, 3), (60, 60, 60), np.uint8)
    img[20:60, 27:70] = (230, 200, 20)            # the real (yellow) object, 3 px wider on the left
    label = np.zeros((H, W), bool)
    label[20:60, 30:70] = True                    # its annotation
    render = label.copy()
    rim = np.zeros((H, W), bool)
    rim[20:60, 27:30] = True
    before = np.abs(img[rim].astype(float) - 60).mean()
    out = clear_objects(img, [label], render, clear_px=4)
    after = np.abs(out[rim].astype(float) - 60).mean()
    assert before > 80 and after < 0.1 * before, (before, after)
    far = np.zeros((H, W), bool)
    far[:, 85:] = True
    assert np.array_equal(out[far], img[far])     # background away from objects untouched
    assert clear_objects(img, [label], render, clear_px=0) is img
