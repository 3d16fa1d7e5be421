"""BCOT layout: reader on a rendered BCOT-format fixture (a shared YCB model moving fast), the bcot
protocol and scoring a GT tracker on it; malformed files give one error line naming the file."""
from __future__ import annotations

import json

import numpy as np
import pytest

from ycbvss.cli import main
from ycbvss.errors import YcbvssError
from ycbvss.io.bcot import (BCOT_TEST_SCENES, format_K_txt, load_bcot_dataset, make_bcot_fixture, read_K_txt,
                            read_pose_txt)


@pytest.fixture(scope="module")
def bcot_root(ycbv_root, tmp_path_factory):
    out = tmp_path_factory.mktemp("bcot")
    return make_bcot_fixture(out, ycbv_root / "models" / "025_mug" / "textured.obj", body="Cat",
                             scenes=("easy_static_suspension", "light_movable_suspension", "complex_movable_handheld"),
                             n_frames=12, seed=3)


def test_k_txt_and_pose_txt(tmp_path):
    p = tmp_path / "K.txt"
    p.write_text("Matx33f K = Matx33f(1046.25, 0, 643.5, 0, 1045.5, 363.25, 0, 0, 1);\n")
    K = read_K_txt(p)
    assert np.allclose(K, [[1046.25, 0, 643.5], [0, 1045.5, 363.25], [0, 0, 1]])
    p.write_text(format_K_txt(K))
    assert np.allclose(read_K_txt(p), K)
    q = tmp_path / "pose.txt"
    q.write_text("1 0 0 0 1 0 0 0 1 10 20 500\n1 0 0 0 1 0 0 0 1 10 20\n")
    with pytest.raises(YcbvssError, match=r"pose.txt: seq frame 1: line 2: expected 12"):
        read_pose_txt(q, "seq")


def test_fixture_loader(bcot_root):
    ds = load_bcot_dataset(bcot_root)
    assert len(ds.scene_ids) == 3 and ds.name == "bcot"
    assert list(ds.models) == [5] and ds.models[5].name == "Cat"          # BCOT body index 5 = Cat
    assert set(ds.sequence_names.values()) == {f"{s}/Cat" for s in ("complex_movable_handheld", "easy_static_suspension",
                                                                      "light_movable_suspension")}
    sc = ds.load_scene(0)
    assert len(sc.frames) == 12 and all(f.rgb_path.is_file() for f in sc.frames)
    img = sc.frames[5].load_rgb()
    assert img.shape == (240, 320, 3) and sc.frames[5].camera.width == 320
    T = sc.frames[5].instances[0].T_m2c
    assert abs(np.linalg.det(T[:3, :3]) - 1) < 1e-6 and T[2, 3] > 100
    # the model's projection at the GT pose lands on the rendered object (not the grey background)
    X = ds.models[5].vertices_mm @ T[:3, :3].T + T[:3, 3]
    uv = X @ sc.frames[5].camera.K.T
    uv = np.round(uv[:, :2] / uv[:, 2:]).astype(int)
    inside = (uv[:, 0] >= 0) & (uv[:, 0] < 320) & (uv[:, 1] >= 0) & (uv[:, 1] < 240)
    hits = np.any(img[uv[inside, 1], uv[inside, 0]] != 96, axis=1)
    assert inside.mean() > 0.9 and hits.mean() > 0.9
    # fast motion, as BCOT: several degrees per frame
    T0, T1 = sc.frames[0].instances[0].T_m2c, sc.frames[1].instances[0].T_m2c
    ang = np.degrees(np.arccos(np.clip((np.trace(T0[:3, :3].T @ T1[:3, :3]) - 1) / 2, -1, 1)))
    assert 1.0 < ang < 10.0
    sub = load_bcot_dataset(bcot_root, ["light_movable_suspension"])
    assert len(sub.scene_ids) == 1 and sub.sequence_names[sub.scene_ids[0]] == "light_movable_suspension/Cat"
    with pytest.raises(YcbvssError, match="BCOT scene 'nope' not found"):
        load_bcot_dataset(bcot_root, ["nope"])


class _GT:
    modality = "rgb"

    def __init__(self, gt):
        self.gt = gt

    def init(self, frame, poses):
        self.objs = sorted(poses)

    def track(self, frame):
        return {o: self.gt[(frame.scene_id, frame.im_id)][o] for o in self.objs}


def test_bcot_protocol_and_gt_scores_100(bcot_root, tmp_path, capsys):
    cfgp = tmp_path / "bcot.json"
    assert main(["benchmark", "make", "--dataset", str(bcot_root), "--protocol", "bcot", "--out", str(cfgp),
                 "--lengths", "3,6", "--seed", "2"]) == 0
    cfg = json.loads(cfgp.read_text())
    test_scenes = [s for s in BCOT_TEST_SCENES if s in ("easy_static_suspension", "light_movable_suspension",
                                                       "complex_movable_handheld")]
    assert cfg["dataset"]["bcot_test_scenes"] == test_scenes            # the split is recorded
    assert {s["sequence"].split("/")[0] for s in cfg["subsequences"]} <= set(test_scenes)
    assert all(1 <= s["step"] <= 4 and not s["removed"] and s["objects"] == [5] for s in cfg["subsequences"])
    out = capsys.readouterr().out
    assert "BCOT test scenes (2)" in out and "easy_static_suspension" not in json.dumps(cfg["subsequences"])
    from ycbvss.eval.benchmark import load_sequences, read_config, run_benchmark
    seqs, _ = load_sequences(bcot_root, "bcot", bcot_scenes=cfg["dataset"]["bcot_test_scenes"])
    gt = {(s.scene_id, im): g for s in seqs for im, g in s.gt.items()}
    run_benchmark(read_config(cfgp), lambda: _GT(gt), tmp_path / "gt", tracker_name="gt")
    assert main(["benchmark", "run", "--config", str(cfgp), "--tracker", "static", "--out", str(tmp_path / "st")]) == 0
    assert main(["benchmark", "score", "--config", str(cfgp), "--results", str(tmp_path / "gt"), str(tmp_path / "st"),
                 "--out", str(tmp_path / "score")]) == 0
    sc = json.loads((tmp_path / "score" / "scores.json").read_text())
    assert sc["options"]["symmetric_obj_ids"] == []
    assert sc["trackers"]["gt"]["add_prj_auc"] == pytest.approx(100.0, abs=1e-9)
    assert sc["trackers"]["static"]["add_prj_auc"] < 90.0                   # the object moves fast
