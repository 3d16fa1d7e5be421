"""BOP reader/writer round trip and every bad-input case of the data layer (issue section 7).

A tiny BOP dataset is written with BopSceneWriter (real BOP ycbv models obj 1/2, 64x48 images),
then corrupted one way at a time. Budget: ~5 s.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from ycbvss.camera import Camera
from ycbvss.errors import YcbvssError
from ycbvss.geometry.so3 import exp_so3
from ycbvss.io.atomic import write_json_atomic
from ycbvss.io.bop import BopSceneWriter, load_dataset, load_models, read_scene_camera, read_scene_gt
from ycbvss.io.mesh import compute_models_info, load_vertices_mm
from ycbvss.io.results import Estimate, read_bop19_csv, write_bop19_csv
from ycbvss.scene import Frame, Instance

K = np.array([[100.0, 0, 31.5], [0, 100.0, 23.5], [0, 0, 1]])


def _pose(w, t):
    T = np.eye(4)
    T[:3, :3] = exp_so3(np.asarray(w, float))
    T[:3, 3] = t
    return T


def make_bop(bop_models_root: Path, root: Path, rgb_dir: str = "rgb", ext: str = "png") -> Path:
    md = root / "models"
    md.mkdir(parents=True)
    info = {}
    for oid in (1, 2):
        src = bop_models_root / "models" / f"obj_{oid:06d}.ply"
        shutil.copy(src, md)
        info[str(oid)] = compute_models_info(load_vertices_mm(src))
    write_json_atomic(md / "models_info.json", info)
    rng = np.random.default_rng(0)
    with BopSceneWriter(root / "test", 48, rgb_ext=ext) as w:
        for im in (1, 2, 3):
            f = Frame(scene_id=48, im_id=im, camera=Camera(K, 64, 48), depth_scale=0.1,
                      instances=[Instance(1, _pose([0.1 * im, 0.2, 0.3], [10, -5, 800 + im])),
                                 Instance(2, _pose([0.3, -0.1 * im, 1.0], [-40, 20, 900]))],
                      T_w2c=_pose([0.2, 0.1, -0.3], [1.5, 2.5, 700]))
            w.write_frame(f, rgb=rng.integers(0, 255, (48, 64, 3), dtype=np.uint8),
                          depth_mm=np.full((48, 64), 812.3, np.float32),
                          masks=[np.ones((48, 64), bool)] * 2, masks_visib=[np.zeros((48, 64), bool)] * 2,
                          gt_info=[{"visib_fract": 0.5}] * 2)
    if rgb_dir != "rgb":
        (root / "test/000048/rgb").rename(root / f"test/000048/{rgb_dir}")
    return root


@pytest.fixture()
def bop(bop_models_root, tmp_path):
    return make_bop(bop_models_root, tmp_path / "ycbv_bop")


def test_round_trip_exact(bop):
    ds = load_dataset(bop, "test")
    assert ds.scene_ids == [48] and sorted(ds.models) == [1, 2]
    assert ds.models[1].name == "002_master_chef_can" and ds.models[2].name == "003_cracker_box"
    assert not ds.models[2].symmetric and load_models(bop / "models", symmetric_obj_ids=(2,))[2].symmetric
    s = ds.load_scene(48)
    assert [f.im_id for f in s.frames] == [1, 2, 3]
    f = s.frames[1]
    T_expect = _pose([0.2, 0.2, 0.3], [10, -5, 802])
    assert np.abs(f.instances[0].T_m2c - T_expect).max() == 0.0       # JSON floats round-trip exactly
    assert np.abs(f.T_w2c - _pose([0.2, 0.1, -0.3], [1.5, 2.5, 700])).max() == 0.0
    assert (f.camera.width, f.camera.height) == (64, 48)
    assert np.abs(f.load_depth_mm() - 812.3).max() < 0.05 + 1e-6         # uint16 at 0.1 mm
    assert f.load_rgb().shape == (48, 64, 3)
    assert f.extra["gt_info"][0]["visib_fract"] == 0.5
    assert (bop / "test/000048/mask/000002_000001.png").is_file()
    assert (bop / "test/000048/mask_visib/000003_000000.png").is_file()
    assert not list((bop / "test/000048").rglob(".tmp-*"))


def test_names_only_for_ycb_video_model_folders(bop, tmp_path):
    other = tmp_path / "lm"
    shutil.copytree(bop / "models", other / "models")
    assert load_models(other / "models")[1].name == ""                   # not YCB-V: no YCB names
    (other / "camera_uw.json").write_text("{}")                           # a BOP ycbv root marker
    assert load_models(other / "models")[1].name == "002_master_chef_can"


@pytest.mark.parametrize("rgb_dir, ext", [("gray", "png"), ("rgb", "jpg")])
def test_gray_dir_and_jpg_images(bop_models_root, tmp_path, rgb_dir, ext):
    root = make_bop(bop_models_root, tmp_path / "b", rgb_dir=rgb_dir, ext=ext)
    f = load_dataset(root, "test").load_scene(48).frames[0]
    assert f.rgb_path.parent.name == rgb_dir and f.rgb_path.suffix == f".{ext}"
    assert f.load_rgb().shape == (48, 64, 3)


def _edit(path: Path, fn) -> None:
    d = json.loads(path.read_text())
    fn(d)
    path.write_text(json.dumps(d))


GT = "test/000048/scene_gt.json"
CAM = "test/000048/scene_camera.json"

BAD_CASES = {
    # name: (file, editor, expected message part, expected location)
    "gt_truncated": (GT, "truncate", "malformed or truncated JSON", None),
    "cam_truncated": (CAM, "truncate", "malformed or truncated JSON", None),
    "R_not_orthonormal": (GT, lambda d: d["2"][1].__setitem__("cam_R_m2c", (1.01 * np.eye(3)).ravel().tolist()),
                          "R is not orthonormal", "scene 48 frame 2 object 2"),
    "t_nan": (GT, lambda d: d["3"][0].__setitem__("cam_t_m2c", [0, float("nan"), 800]),
              "NaN/inf", "scene 48 frame 3 object 1"),
    "R_inf": (GT, lambda d: d["1"][0].__setitem__("cam_R_m2c", [float("inf")] + [0] * 8),
              "NaN/inf", "scene 48 frame 1 object 1"),
    "behind_camera": (GT, lambda d: d["1"][1].__setitem__("cam_t_m2c", [0, 0, -500]),
                      "behind the camera", "scene 48 frame 1 object 2"),
    "unknown_obj_id": (GT, lambda d: d["2"][0].__setitem__("obj_id", 7), "obj_id 7 has no usable model: no model file",
                       "scene 48 frame 2 object 7"),
    "K_not_3x3": (CAM, lambda d: d["2"].__setitem__("cam_K", [100, 0, 31.5, 0, 100, 23.5, 0, 0]),
                  "must be 3x3", "scene 48 frame 2"),
    "K_singular": (CAM, lambda d: d["3"].__setitem__("cam_K", [0] * 9), "singular", "scene 48 frame 3"),
    "cam_R_w2c_bad": (CAM, lambda d: d["1"].__setitem__("cam_R_w2c", [2, 0, 0, 0, 1, 0, 0, 0, 1]),
                      "cam_R_w2c is not orthonormal", "scene 48 frame 1"),
}


@pytest.mark.parametrize("case", sorted(BAD_CASES))
def test_bad_scene_json_gives_one_named_error(bop, case):
    rel, edit, msg, loc = BAD_CASES[case]
    p = bop / rel
    if edit == "truncate":
        p.write_text(p.read_text()[:57])
    else:
        _edit(p, edit)
    with pytest.raises(YcbvssError) as e:
        load_dataset(bop, "test").load_scene(48)
    text = str(e.value)
    assert Path(rel).name in text and msg in text, text
    if loc:
        assert loc in text, text


def test_missing_frame_image_and_model(bop):
    (bop / "test/000048/rgb/000002.png").unlink()
    with pytest.raises(YcbvssError, match=r"000002.png: scene 48 frame 2: missing frame image"):
        load_dataset(bop, "test").load_scene(48)
    (bop / "models/obj_000001.ply").unlink()
    with pytest.raises(YcbvssError, match=r"obj_000001.ply: object 1: missing model file"):
        load_models(bop / "models")


def test_model_in_metres_is_rejected(bop):
    _edit(bop / "models/models_info.json", lambda d: d["2"].__setitem__("diameter", 0.269573))
    with pytest.raises(YcbvssError, match=r"models_info.json: object 2: diameter 0.269573 < 1: model apparently in metres"):
        load_models(bop / "models")


def test_malformed_models_info(bop):
    p = bop / "models/models_info.json"
    p.write_text(p.read_text()[:-20])
    with pytest.raises(YcbvssError, match=r"models_info.json: malformed or truncated JSON"):
        load_models(p.parent)


def test_results_csv_unknown_obj_id_and_truncated(bop, tmp_path):
    models = load_models(bop / "models")
    ok = tmp_path / "ok.csv"
    write_bop19_csv(ok, [Estimate(48, 1, 2, 0.9, _pose([0, 0, 0.1], [0, 0, 900]))])
    assert len(read_bop19_csv(ok, known_obj_ids=models.keys())) == 1
    bad = tmp_path / "bad.csv"
    write_bop19_csv(bad, [Estimate(48, 1, 5, 0.9, _pose([0, 0, 0.1], [0, 0, 900]))])
    with pytest.raises(YcbvssError, match=r"bad.csv.*object 5"):
        read_bop19_csv(bad, known_obj_ids=models.keys())
    trunc = tmp_path / "trunc.csv"
    trunc.write_text(ok.read_text()[:60])
    with pytest.raises(YcbvssError, match=r"trunc.csv"):
        read_bop19_csv(trunc, known_obj_ids=models.keys())


def test_scene_json_readers_direct(bop):
    cams = read_scene_camera(bop / CAM, 48)
    assert cams[1]["depth_scale"] == 0.1 and cams[1]["K"].shape == (3, 3)
    gt = read_scene_gt(bop / GT, 48, known_obj_ids=[1, 2])
    assert [i.obj_id for i in gt[3]] == [1, 2] and [i.gt_id for i in gt[3]] == [0, 1]


def test_annotation_only_scene_loads_without_images(bop):
    shutil.rmtree(bop / "test/000048/rgb")
    shutil.rmtree(bop / "test/000048/depth")
    write_json_atomic(bop / "camera.json", {"width": 64, "height": 48, "fx": 100.0})
    f = load_dataset(bop, "test").load_scene(48).frames[0]
    assert f.rgb_path is None and f.depth_path is None and (f.camera.width, f.camera.height) == (64, 48)
    assert len(f.instances) == 2


@pytest.mark.parametrize("case", ["gt_truncated", "in_metres", "unknown_obj_in_results", "K_singular"])
def test_cli_reports_bad_bop_input_in_one_line(bop, tmp_path, capsys, case):
    """Through `ycbvss eval` (which reads the BOP files with this data layer): exit 2, one line."""
    from ycbvss.cli import main
    csv = tmp_path / "res.csv"
    write_bop19_csv(csv, [Estimate(48, 1, 5 if case == "unknown_obj_in_results" else 2, 0.9,
                                   _pose([0, 0, 0.1], [0, 0, 900]))])
    if case == "gt_truncated":
        p = bop / GT
        p.write_text(p.read_text()[:80])
        expect = "scene_gt.json"
    elif case == "in_metres":
        _edit(bop / "models/models_info.json", lambda d: d["1"].__setitem__("diameter", 0.172))
        expect = "apparently in metres"
    elif case == "K_singular":
        _edit(bop / CAM, lambda d: d["2"].__setitem__("cam_K", [0] * 9))
        expect = "scene_camera.json: scene 48 frame 2"
    else:
        expect = "res.csv"
    rc = main(["eval", "--dataset", str(bop), "--split", "test", "--results", str(csv),
               "--out", str(tmp_path / "ev"), "--no-curves"])
    err = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip() and "warning" not in ln]
    assert rc == 2 and len(err) == 1 and expect in err[0] and "Traceback" not in err[0], err
