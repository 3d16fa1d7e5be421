"""Original YCB-Video reader on ../shared/data/ycbv, and its bad-input errors.

Budget: ~6 s.
"""
from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from ycbvss.errors import YcbvssError
from ycbvss.io.ycbv import list_frames, load_ycbv_dataset, parse_videos, read_meta_frame


def test_dataset_lists_videos_frames_and_models(ycbv_root):
    ds = load_ycbv_dataset(ycbv_root)
    assert ds.scene_ids == [0, 1]
    assert len(ds.models) == 21 and ds.models[13].symmetric and not ds.models[1].symmetric
    assert ds.models[1].name == "002_master_chef_can" and ds.models[1].unit_scale == 1000.0
    assert ds.models[25 - 11].textureless                       # obj 14 = 025_mug
    assert list_frames(ycbv_root, 0) == list(range(1, 11))
    s0 = ds.load_scene(0)
    assert [f.im_id for f in s0.frames] == list(range(1, 11))
    f = s0.frames[0]
    assert [i.obj_id for i in f.instances] == [8, 14, 21]           # cls_indexes of 0000/000001
    assert abs(f.depth_scale - 0.1) < 1e-12                         # factor_depth 10000 -> 0.1 mm/unit
    assert f.label_path is not None and f.T_w2c is not None
    meta = scipy.io.loadmat(str(f.extra["meta_path"]))
    assert np.abs(f.instances[0].T_m2c[:3, 3] - 1000 * meta["poses"][:, 3, 0]).max() < 1e-9
    assert np.abs(f.T_w2c[:3, 3] - 1000 * meta["rotation_translation_matrix"][:, 3]).max() < 1e-9
    # the camera K of video 0000 is the manifest 'uw' camera
    assert abs(f.camera.fx - 1066.778) < 1e-6 and abs(f.camera.cy - 241.3109) < 1e-6
    # depth in mm: YCB-V depth / 10000 m; objects at ~0.6 m
    d = f.load_depth_mm()
    assert 400 < np.median(d[d > 0]) < 1500
    lab = f.load_label()
    assert set(np.unique(lab)) - {0} == {8, 14, 21}


def test_model_diameters_agree_with_official_points(ycbv_root):
    """Shared aligned scans vs official YCB-V points.xyz: diameters within 3 %."""
    from ycbvss.io.mesh import diameter_mm, load_vertices_mm
    ds = load_ycbv_dataset(ycbv_root, videos=[0])
    rel = {oid: m.diameter_mm / diameter_mm(load_vertices_mm(m.info["points_xyz"], 1000.0)) - 1
           for oid, m in ds.models.items()}
    worst = max(rel, key=lambda k: abs(rel[k]))
    assert abs(rel[worst]) < 0.03, (worst, rel[worst])


def test_parse_videos():
    assert parse_videos("0000,0001") == [0, 1]
    assert parse_videos("0-3,7") == [0, 1, 2, 3, 7]
    assert parse_videos(None) is None
    with pytest.raises(YcbvssError, match="bad video list"):
        parse_videos("00a1")


def make_ycbv_copy(ycbv_root: Path, dst: Path, n_frames: int = 2) -> Path:
    """A small writable YCB-Video root: video 0000 frames 1..n (files copied), models symlinked."""
    (dst / "data" / "0000").mkdir(parents=True)
    for name in ("models", "image_sets", "cameras"):
        (dst / name).symlink_to(ycbv_root / name)
    for im in range(1, n_frames + 1):
        for suf in ("color.png", "depth.png", "label.png", "meta.mat"):
            shutil.copy(ycbv_root / "data" / "0000" / f"{im:06d}-{suf}", dst / "data" / "0000")
    return dst


def edit_meta(path: Path, **changes) -> None:
    m = {k: v for k, v in scipy.io.loadmat(str(path)).items() if not k.startswith("__")}
    m.update(changes)
    scipy.io.savemat(str(path), m, do_compression=True)


def _poses(root):
    return scipy.io.loadmat(str(root / "data/0000/000002-meta.mat"))["poses"]


@pytest.mark.parametrize("case, match", [
    ("R_scaled", "R is not orthonormal"),
    ("nan", "NaN/inf"),
    ("behind", "behind the camera"),
    ("K_singular", "singular"),
    ("K_shape", "must be 3x3"),
])
def test_bad_meta_mat_names_file_frame_object(ycbv_root, tmp_path, case, match):
    root = make_ycbv_copy(ycbv_root, tmp_path / "ycbv")
    meta = root / "data/0000/000002-meta.mat"
    P = _poses(root)
    if case == "R_scaled":
        P[:, :3, 1] *= 1.01
        edit_meta(meta, poses=P)
    elif case == "nan":
        P[0, 3, 1] = np.nan
        edit_meta(meta, poses=P)
    elif case == "behind":
        P[2, 3, 1] = -0.6
        edit_meta(meta, poses=P)
    elif case == "K_singular":
        edit_meta(meta, intrinsic_matrix=np.zeros((3, 3)))
    elif case == "K_shape":
        edit_meta(meta, intrinsic_matrix=np.eye(4))
    with pytest.raises(YcbvssError, match=match) as e:
        load_ycbv_dataset(root).load_scene(0)
    msg = str(e.value)
    assert "000002-meta.mat" in msg and "scene 0 frame 2" in msg
    if case in ("R_scaled", "nan", "behind"):
        assert "object 14" in msg                       # second instance of frame 2 is 025_mug


def test_missing_frame_file_and_truncated_meta(ycbv_root, tmp_path):
    root = make_ycbv_copy(ycbv_root, tmp_path / "ycbv")
    (root / "data/0000/000002-color.png").unlink()
    with pytest.raises(YcbvssError, match=r"000002-color.png: scene 0 frame 2: missing color.png"):
        load_ycbv_dataset(root).load_scene(0)
    root2 = make_ycbv_copy(ycbv_root, tmp_path / "ycbv2")
    meta = root2 / "data/0000/000001-meta.mat"
    meta.write_bytes(meta.read_bytes()[:500])
    with pytest.raises(YcbvssError, match=r"000001-meta.mat: scene 0 frame 1: corrupt or truncated meta.mat"):
        load_ycbv_dataset(root2).load_scene(0)


def test_intrinsics_disagreeing_with_manifest_warn_once(ycbv_root, tmp_path):
    root = make_ycbv_copy(ycbv_root, tmp_path / "ycbv")
    for im in (1, 2):
        K = np.array([[1000.0, 0, 320], [0, 1000.0, 240], [0, 0, 1]])
        edit_meta(root / f"data/0000/{im:06d}-meta.mat", intrinsic_matrix=K)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        s = load_ycbv_dataset(root).load_scene(0)
    msgs = [str(x.message) for x in w if "intrinsic_matrix" in str(x.message)]
    assert len(msgs) == 1 and "'uw'" in msgs[0]
    assert s.frames[0].camera.fx == 1000.0                      # meta.mat's K is used


def test_read_meta_frame_units(ycbv_root):
    m = read_meta_frame(ycbv_root / "data/0001/000001-meta.mat", 1, 1)
    assert m["obj_ids"] == [1, 2, 3, 5]
    assert all(400 < T[2, 3] < 2000 for T in m["T_m2c"])         # mm
