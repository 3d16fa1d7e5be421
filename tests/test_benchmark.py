"""The tracking benchmark (issue 11): protocol statistics, JSON contract, runner/resume, external CSV
results, and scores of known trackers (GT = 100, nothing = 0, 5 mm depth offset = analytic AUC)
on the real shared YCB-V clips."""
from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from ycbvss.cli import main
from ycbvss.eval.benchmark import (ProtocolOptions, StaticTracker, load_models, load_sequences, make_protocol,
                                   protocol_stats, read_config, run_benchmark, write_results)
from ycbvss.eval.benchmark.protocol import occluders
from ycbvss.eval.benchmark.sources import Sequence
from ycbvss.geometry.so3 import exp_so3
from ycbvss.io.atomic import dumps_json


# ----------------------------------------------------------------------------- protocol statistics
def _synthetic(n_seq=12, seed=3):
    """YCB-V-like sequences (1000-2500 frames, 5-7 objects incl. the wood block, objects overlapping
    in the image) with toy box models."""
    rng = np.random.default_rng(seed)
    box = np.array([[x, y, z] for x in (-40, 40) for y in (-40, 40) for z in (-60, 60)], float)
    models = {o: SimpleNamespace(vertices_mm=box, label=f"obj{o}") for o in range(1, 22)}
    K = np.array([[1066.8, 0, 313.0], [0, 1067.5, 241.3], [0, 0, 1]])
    seqs = []
    for s in range(n_seq):
        n = int(rng.integers(1000, 2500))
        objs = sorted(set(rng.choice(np.r_[1:16, 17:22], 5, replace=False).tolist()) | ({16} if s % 2 else set()))
        base = {o: np.r_[rng.uniform(-120, 120, 2), rng.uniform(700, 1100)] for o in objs}
        Ts = np.tile(np.eye(4), (n, 1, 1))
        Ts[:, :3, :3] = exp_so3(np.c_[np.zeros(n), 0.001 * np.arange(1, n + 1), np.zeros(n)])
        per_obj = {}
        for o in objs:
            To = Ts.copy()
            To[:, :3, 3] = base[o]
            per_obj[o] = To
        gt = {im: {o: per_obj[o][im - 1] for o in objs} for im in range(1, n + 1)}
        seqs.append(Sequence(48 + s, f"{48 + s:06d}", list(range(1, n + 1)), {im: K for im in range(1, n + 1)}, gt))
    return seqs, models


@pytest.fixture(scope="module")
def synthetic():
    return _synthetic()


def test_protocol_statistics_ycbv(synthetic):
    seqs, models = synthetic
    info = {"name": "synthetic", "root": "/nowhere", "layout": "bop", "split": "test"}
    cfg = make_protocol(seqs, info, ProtocolOptions("ycbv", seed=7), models)
    st = protocol_stats(cfg)
    fpl = st["frames_per_length"]
    assert sorted(fpl) == [25, 50, 100, 200]
    assert max(fpl.values()) <= 1.05 * min(fpl.values())              # frames per length equal within 5 %
    n_total = sum(len(s.im_ids) for s in seqs)
    assert 0.8 * n_total <= st["n_frames"] <= 1.2 * n_total          # coverage 1
    by_seq = {s.scene_id: s for s in seqs}
    for sub in cfg["subsequences"]:
        assert 5 <= sub["step"] <= 15
        assert sub["direction"] in (1, -1)
        assert len(sub["frames"]) == sub["length"]
        d = np.diff(sub["frames"])
        assert np.all(d == sub["step"] * sub["direction"])
        seq = by_seq[sub["scene_id"]]
        assert set(sub["frames"]) <= set(seq.im_ids)
        assert 16 not in sub["objects"] and 16 not in sub["removed"]
        assert len(sub["removed"]) <= 1
        assert not set(sub["removed"]) & set(sub["objects"])
        f0 = sub["frames"][0]
        assert set(sub["objects"]) | set(sub["removed"]) == set(seq.gt[f0]) - {16}
        for o in sub["objects"]:                                      # init = GT of the first frame
            T = seq.gt[f0][o]
            assert np.allclose(np.reshape(sub["init"][str(o)]["R"], (3, 3)), T[:3, :3])
            assert np.allclose(sub["init"][str(o)]["t"], T[:3, 3])
        if sub["removed"]:                                            # the removed object occludes another one
            objs = sub["objects"] + sub["removed"]
            assert sub["removed"][0] in occluders(seq.gt[f0], seq.K[f0], {o: models[o].vertices_mm for o in objs},
                                                  objs)
    assert st["directions"]["forward"] > 0 and st["directions"]["backward"] > 0
    assert 0 < st["removed"]["subsequences_with_removal"] < st["n_subsequences"]
    assert set(st["steps"]) <= set(range(5, 16)) and len(st["steps"]) >= 8
    # same seed -> same JSON; another seed -> another split
    again = make_protocol(seqs, info, ProtocolOptions("ycbv", seed=7), models)
    assert dumps_json(again) == dumps_json(cfg)
    other = make_protocol(seqs, info, ProtocolOptions("ycbv", seed=8), models)
    assert dumps_json(other) != dumps_json(cfg)


def test_protocol_bcot_steps_and_no_removal(synthetic):
    seqs, models = synthetic
    cfg = make_protocol(seqs[:4], {"name": "x", "layout": "bcot"}, ProtocolOptions("bcot", seed=1), models)
    assert {s["step"] for s in cfg["subsequences"]} <= {1, 2, 3, 4}
    assert all(not s["removed"] for s in cfg["subsequences"])
    assert 16 in {o for s in cfg["subsequences"] for o in s["objects"]}   # only the ycbv protocol drops it


def test_protocol_too_short_names_scene(synthetic):
    seqs, models = synthetic
    short = [Sequence(s.scene_id, s.name, s.im_ids[:50], s.K, s.gt) for s in seqs[:2]]
    from ycbvss.errors import YcbvssError
    with pytest.raises(YcbvssError, match=r"scene 4[89].*no sequence fits a subsequence of 25 frames"):
        make_protocol(short, {}, ProtocolOptions("ycbv"), models)


# ----------------------------------------------------------------------------- real frames
class OracleTracker:
    """Returns the GT (read from the dataset by the test, never given by the runner); optionally
    offset in camera depth by ``dz_mm``."""

    modality = "rgb"

    def __init__(self, gt: dict, dz_mm: float = 0.0):
        self.gt, self.dz, self.objs = gt, dz_mm, []

    def init(self, frame, poses):
        self.objs = sorted(poses)
        assert frame.rgb.ndim == 3 and frame.rgb.dtype == np.uint8

    def track(self, frame):
        out = {}
        for o in self.objs:
            T = self.gt[(frame.scene_id, frame.im_id)][o].copy()
            T[2, 3] += self.dz
            out[o] = T
        return out


class EmptyTracker(StaticTracker):
    def track(self, frame):
        return {}


@pytest.fixture(scope="module")
def real_cfg(ycbv_root, tmp_path_factory):
    d = tmp_path_factory.mktemp("bench")
    cfgp = d / "cfg.json"
    assert main(["benchmark", "make", "--dataset", str(ycbv_root), "--protocol", "ycbv", "--out", str(cfgp),
                 "--lengths", "2,4", "--steps", "1,2", "--coverage", "3", "--seed", "5"]) == 0
    seqs, _ = load_sequences(ycbv_root)
    gt = {(s.scene_id, im): g for s in seqs for im, g in s.gt.items()}
    return d, cfgp, read_config(cfgp), gt, seqs


def test_make_json_contract_real(real_cfg, ycbv_root, capsys):
    d, cfgp, cfg, gt, seqs = real_cfg
    raw = json.loads(cfgp.read_text())
    for k in ("version", "protocol", "seed", "dataset", "subsequences"):
        assert k in raw
    assert raw["protocol"] == "ycbv" and raw["seed"] == 5 and raw["dataset"]["layout"] == "ycbv"
    st = protocol_stats(raw)
    assert st["frames_per_length"][2] == st["frames_per_length"][4]
    for s in raw["subsequences"]:
        for k in ("scene_id", "frames", "step", "direction", "objects", "removed", "init", "K"):
            assert k in s
        assert s["scene_id"] in (0, 1) and 1 <= s["step"] <= 2
        assert set(s["init"]) == {str(o) for o in s["objects"]}
    # make needs no image: the same JSON from a copy with only meta.mat files
    import shutil
    lite = d / "lite"
    shutil.copytree(ycbv_root / "models", lite / "models")
    shutil.copytree(ycbv_root / "image_sets", lite / "image_sets")
    for v in ("0000", "0001"):
        (lite / "data" / v).mkdir(parents=True)
        for p in (ycbv_root / "data" / v).glob("*-meta.mat"):
            shutil.copy(p, lite / "data" / v / p.name)
    out2 = d / "cfg_lite.json"
    assert main(["benchmark", "make", "--dataset", str(lite), "--protocol", "ycbv", "--out", str(out2),
                 "--lengths", "2,4", "--steps", "1,2", "--coverage", "3", "--seed", "5"]) == 0
    a, b = json.loads(out2.read_text()), raw
    a["dataset"].pop("root"), b["dataset"].pop("root")
    assert a == b
    out = capsys.readouterr().out
    assert "| length | subsequences | frames |" in out and "directions:" in out and "removed occluders" in out


def _score(cfgp, dirs, out):
    assert main(["benchmark", "score", "--config", str(cfgp), "--results", *map(str, dirs), "--out", str(out)]) == 0
    return json.loads((out / "scores.json").read_text())["trackers"]


def test_scores_gt_empty_and_depth_offset(real_cfg, ycbv_root):
    d, cfgp, cfg, gt, seqs = real_cfg
    runs = {"gt": OracleTracker(gt), "empty": EmptyTracker(), "dz5": OracleTracker(gt, 5.0)}
    for name, trk in runs.items():
        info = run_benchmark(cfg, lambda trk=trk: trk, d / name, tracker_name=name)
        assert info["done"] == len(cfg["subsequences"])
    sc = _score(cfgp, [d / n for n in runs], d / "score")
    assert sc["gt"]["add_prj_auc"] == pytest.approx(100.0, abs=1e-9)
    assert sc["gt"]["sr_5cm5deg"] == pytest.approx(100.0)
    assert sc["empty"]["add_prj_auc"] == 0.0 and sc["empty"]["counts"]["n_estimates"] == 0
    # 5 mm in depth: ADD = 5 mm for every point -> ADD-AUC 95 exactly; PRJ of a point at depth z
    # projecting at p is |p - c| * 5 / (z + 5) (c = principal point)
    assert sc["dz5"]["add_auc"] == pytest.approx(95.0, abs=1e-9)
    models = load_models(ycbv_root, "ycbv")
    per_obj: dict[int, list[float]] = {}
    for s in cfg["subsequences"]:
        K = np.reshape(s["K"], (3, 3))
        for im in s["frames"][1:]:
            for o in s["objects"]:
                T = gt[(s["scene_id"], im)][o]
                X = models[o].vertices_mm @ T[:3, :3].T + T[:3, 3]
                p = X @ K.T
                p = p[:, :2] / p[:, 2:]
                prj = np.mean(np.linalg.norm(p - K[:2, 2], axis=1) * 5.0 / (X[:, 2] + 5.0))
                per_obj.setdefault(o, []).append(max(0.0, 1 - prj / 10.0) * 100)
    prj_auc = np.mean([np.mean(v) for v in per_obj.values()])
    assert sc["dz5"]["prj_auc"] == pytest.approx(prj_auc, rel=1e-9)
    assert sc["dz5"]["add_prj_auc"] == pytest.approx((95.0 + prj_auc) / 2, rel=1e-9)
    ranking = (d / "score" / "ranking.md").read_text()
    assert ranking.index("| empty") < ranking.index("| dz5") < ranking.index("| gt")   # ascending, as the paper
    assert "[1]" in ranking and (d / "score" / "curves.png").stat().st_size > 10_000
    assert (d / "score" / "ranking.tex").read_text().count(r"\\") >= 4
    assert (d / "score" / "ranking.csv").read_text().startswith("method,")


def test_resume_external_csv_and_bad_input(real_cfg, capsys):
    d, cfgp, cfg, gt, seqs = real_cfg
    out = d / "static"
    run_benchmark(cfg, StaticTracker, out, tracker_name="static")
    files = sorted(out.glob("*.csv"))
    assert len(files) == len(cfg["subsequences"])
    stamps = {p.name: p.stat().st_mtime_ns for p in files}
    files[1].unlink()
    info = run_benchmark(cfg, StaticTracker, out, tracker_name="static")
    assert info == {**info, "done": 1, "skipped": len(files) - 1}
    assert all(p.stat().st_mtime_ns == stamps[p.name] for p in sorted(out.glob("*.csv")) if p != files[1])
    # an external tracker: CSVs only (no run.json), half of the subsequences missing -> failures
    ext = d / "external"
    half = cfg["subsequences"][: len(cfg["subsequences"]) // 2]
    for s in half:
        write_results(ext, s["id"], [(im, o, gt[(s["scene_id"], im)][o], 0.01) for im in s["frames"][1:]
                                     for o in s["objects"]])
    sc = _score(cfgp, [ext], d / "score_ext")
    n_half = sum((len(s["frames"]) - 1) * len(s["objects"]) for s in half)
    assert sc["external"]["counts"]["n_estimates"] == n_half
    assert 0 < sc["external"]["add_prj_auc"] < 100
    # bad input: one error line naming the file and line, exit 2, no traceback
    bad = d / "bad"
    bad.mkdir()
    (bad / "00000.csv").write_text("im_id,obj_id,R,t,time\n3,8,1 0 0 0 1 0 0 0,0 0 500,0.1\n")
    capsys.readouterr()
    assert main(["benchmark", "score", "--config", str(cfgp), "--results", str(bad), "--out", str(d / "x")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "00000.csv" in err[0] and "line 2" in err[0] and "frame 3 object 8" in err[0]
    broken = d / "broken.json"
    raw = json.loads(cfgp.read_text())
    del raw["subsequences"][2]["init"]
    broken.write_text(json.dumps(raw))
    assert main(["benchmark", "run", "--config", str(broken), "--tracker", "static", "--out", str(d / "y")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "broken.json" in err[0] and "subsequence 2" in err[0]


class DepthTracker(StaticTracker):
    modality = "rgbd"

    def track(self, frame):
        assert frame.depth_mm is not None and frame.depth_mm.shape == frame.rgb.shape[:2]
        assert 300 < np.median(frame.depth_mm[frame.depth_mm > 0]) < 3000      # mm
        return super().track(frame)


def test_rgbd_tracker_gets_depth(real_cfg):
    d, cfgp, cfg, gt, seqs = real_cfg
    info = run_benchmark(cfg, lambda: DepthTracker(), d / "rgbd", subsequence_ids=[0, 1])
    assert info["done"] == 2 and json.loads((d / "rgbd" / "run.json").read_text())["modality"] == "rgbd"


def test_baseline_tracker_on_real_frames(real_cfg):
    """The shipped baseline runs end to end on real frames (two short subsequences) and tracks."""
    d, cfgp, cfg, gt, seqs = real_cfg
    ids = [s["id"] for s in cfg["subsequences"] if len(s["frames"]) == 2][:2]
    assert main(["benchmark", "run", "--config", str(cfgp), "--tracker", "baseline", "--out", str(d / "base"),
                 "--subsequences", ",".join(map(str, ids))]) == 0
    rows = [ln for i in ids for ln in (d / "base" / f"{i:05d}.csv").read_text().splitlines()[1:]]
    n = sum(len(s["objects"]) for s in cfg["subsequences"] if s["id"] in ids)
    assert len(rows) == n
    from ycbvss.eval.benchmark.results import read_results
    for i in ids:
        s = cfg["subsequences"][i]
        for (im, o), (R, t, _) in read_results(d / "base" / f"{i:05d}.csv").items():
            T = gt[(s["scene_id"], im)][o]
            assert np.linalg.norm(t - T[:3, 3]) < 40.0          # stays near the (2 cm off) YCB-V GT
