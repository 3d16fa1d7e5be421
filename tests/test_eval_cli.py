"""`ycbvss eval` end to end on a tiny BOP dataset written in tmp_path (no images), bad input.
Budget: < 15 s."""
from __future__ import annotations

import csv
import json
import subprocess
import sys

import numpy as np
import pytest

from ycbvss.cli import main
from ycbvss.geometry.so3 import exp_so3
from ycbvss.io.results import Estimate, write_bop19_csv

K = [1066.778, 0.0, 312.9869, 0.0, 1067.487, 241.3109, 0.0, 0.0, 1.0]


@pytest.fixture(scope="module")
def tiny_bop(tmp_path_factory):
    import trimesh
    root = tmp_path_factory.mktemp("bop")
    md = root / "models"
    md.mkdir()
    box = trimesh.creation.box(extents=(50.0, 80.0, 120.0))
    bowl = trimesh.creation.cylinder(radius=80.0, height=60.0, sections=180)
    info = {}
    for oid, mesh in ((1, box), (13, bowl)):
        mesh.export(md / f"obj_{oid:06d}.ply")
        info[str(oid)] = {"diameter": float(np.linalg.norm(mesh.extents))}
    (md / "models_info.json").write_text(json.dumps(info))
    sd = root / "test" / "000048"
    sd.mkdir(parents=True)
    rng = np.random.default_rng(0)
    gt, cam, poses = {}, {}, {}
    for im in (1, 2, 3):
        cam[str(im)] = {"cam_K": K, "depth_scale": 0.1}
        entries = []
        for oid in (1, 13):
            R = exp_so3(rng.normal(size=3))
            t = np.array([rng.uniform(-80, 80), rng.uniform(-60, 60), rng.uniform(700, 1000)])
            poses[(im, oid)] = (R, t)
            entries.append({"cam_R_m2c": R.reshape(-1).tolist(), "cam_t_m2c": t.tolist(), "obj_id": oid})
        gt[str(im)] = entries
    (sd / "scene_gt.json").write_text(json.dumps(gt))
    (sd / "scene_camera.json").write_text(json.dumps(cam))
    return root, poses


def _write_results(path, poses, skip=(), offset=np.array([3.0, -4.0, 12.0]), extra=()):
    ests = []
    for (im, oid), (R, t) in sorted(poses.items()):
        if (im, oid) in skip:
            continue
        Rz = exp_so3(np.array([0, 0, np.radians(40.0)])) if oid == 13 else np.eye(3)
        T = np.eye(4)
        T[:3, :3], T[:3, 3] = R @ Rz, t + offset
        ests.append(Estimate(48, im, oid, 0.9, T, 0.1))
    ests.extend(extra)
    write_bop19_csv(path, ests)


def test_cli_end_to_end(tiny_bop, tmp_path, capsys):
    root, poses = tiny_bop
    res = tmp_path / "res.csv"
    _write_results(res, poses, skip={(3, 1)})
    out = tmp_path / "out"
    rc = main(["eval", "--dataset", str(root), "--split", "test", "--results", str(res), "--out", str(out),
               "--symmetric", "13"])
    assert rc == 0
    stdout = capsys.readouterr().out
    assert "| all |" in stdout and "ADD-PRJ-AUC" in stdout
    rows = list(csv.DictReader(open(out / "errors.csv")))
    assert len(rows) == 6
    by = {(int(r["im_id"]), int(r["obj_id"])): r for r in rows}
    r = by[(1, 1)]
    assert abs(float(r["tx_mm"]) - 3) < 1e-5 and abs(float(r["ty_mm"]) - 4) < 1e-5
    assert abs(float(r["tz_mm"]) - 12) < 1e-5 and float(r["r_deg"]) < 1e-3
    assert abs(float(r["add_mm"]) - 13.0) < 1e-4          # pure translation of norm 13
    assert by[(3, 1)]["add_mm"] == "" and by[(3, 1)]["prj_px"] == ""   # missing estimate
    bowl = by[(1, 13)]
    # the bowl (cylinder) estimate is turned 40 deg about its axis: ADD-S sees only the translation
    assert float(bowl["adds_mm"]) <= 13.0 + 1e-4 and float(bowl["add_mm"]) > 40.0
    assert abs(float(bowl["r_deg"]) - 40.0) < 1e-3
    s = json.loads((out / "summary.json").read_text())
    add1 = 2 * (1 - 13.0 / 100) * 100 / 3                    # obj 1: two at 13 mm, one missing
    assert abs(s["per_object"]["1"]["add_auc"] - add1) < 1e-3
    assert abs(s["add_auc"] - (s["per_object"]["1"]["add_auc"] + s["per_object"]["13"]["add_auc"]) / 2) < 1e-9
    assert abs(s["add_prj_auc"] - (s["add_auc"] + s["prj_auc"]) / 2) < 1e-9
    assert s["per_object"]["13"]["symmetric"] is True and s["counts"]["n_gt_missing"] == 1
    assert abs(s["sr_5cm5deg"] - (2 / 3 * 100 + 0.0) / 2) < 1e-9   # bowl rotated 40 deg fails SR
    assert (out / "curves.png").stat().st_size > 10_000
    assert (out / "table.md").read_text().count("\n") >= 4 and (out / "table.tex").is_file()
    # '--symmetric' with no id: the bowl is scored with ADD, which sees the 40 deg turn
    rc = main(["eval", "--dataset", str(root), "--split", "test", "--results", str(res), "--out",
               str(tmp_path / "o2"), "--symmetric", "--no-curves"])
    s2 = json.loads((tmp_path / "o2" / "summary.json").read_text())
    assert rc == 0 and s2["per_object"]["13"]["add_auc"] < s["per_object"]["13"]["add_auc"] - 10


def test_cli_bad_input_one_line_exit_2(tiny_bop, tmp_path, capsys):
    root, poses = tiny_bop
    bad = tmp_path / "bad.csv"
    bad.write_text("scene_id,im_id,obj_id,score,R,t,time\n48,1,1,0.9,1 0 0 0 1 0,0 0 500,1\n")
    rc = main(["eval", "--dataset", str(root), "--split", "test", "--results", str(bad), "--out",
               str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "line 2" in err[0] and "Traceback" not in err[0]
    unk = tmp_path / "unk.csv"
    T = np.eye(4)
    T[2, 3] = 800.0
    write_bop19_csv(unk, [Estimate(48, 1, 5, 1.0, T)])
    rc = main(["eval", "--dataset", str(root), "--split", "test", "--results", str(unk), "--out",
               str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "unknown obj_id 5" in err[0]
    assert not (tmp_path / "o" / "errors.csv").exists()


def test_cli_subprocess_no_traceback(tiny_bop, tmp_path):
    root, poses = tiny_bop
    rc = subprocess.run([sys.executable, "-m", "ycbvss.cli", "eval", "--dataset", str(root), "--split",
                         "nosplit", "--results", str(tmp_path / "x.csv"), "--out", str(tmp_path / "o")],
                        capture_output=True, text=True, timeout=60)
    assert rc.returncode == 2 and "Traceback" not in rc.stderr and len(rc.stderr.strip().splitlines()) == 1
