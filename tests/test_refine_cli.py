"""`ycbvss refine` end to end on a small BOP dataset written from a procedural scene. Budget: ~20 s."""
from __future__ import annotations

import json

import numpy as np
import pytest

from ycbvss.cli import main


@pytest.fixture(scope="module")
def bop_root(tmp_path_factory):
    from ycbvss.io.bop import BopSceneWriter
    from ycbvss.io.results import Estimate, write_bop19_csv
    from ycbvss.procedural.io import write_models
    from ycbvss.procedural.render import render_frame_fast
    from ycbvss.procedural.scene import make_scene
    from ycbvss.refine.deviation import deviate_scene

    root = tmp_path_factory.mktemp("bop")
    ps = make_scene(seed=1, n_frames=4, width=320, height=240, arc_deg=30)
    write_models(ps, root / "models")
    with BopSceneWriter(root / "test", 1) as w:
        for f in ps.frames:
            w.write_frame(f, rgb=render_frame_fast(ps, f, noise_sigma=1.0)[0])
    init = deviate_scene(ps.T_m2w, {f.im_id: f.T_w2c for f in ps.frames}, np.random.default_rng(5),
                         t_sigma_mm=(2.0, 2.0, 15.0), r_sigma_deg=1.5)
    write_bop19_csv(root / "init.csv", [Estimate(1, im, o, 1.0, T) for (im, o), T in init.items()])
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in ps.frames for i in f.instances}
    return root, init, gt


def test_cli_refine_writes_all_outputs(bop_root, tmp_path):
    from ycbvss.io.bop import read_scene_camera, read_scene_gt
    from ycbvss.io.results import read_bop19_csv

    root, init, gt = bop_root
    out = tmp_path / "out"
    rc = main(["refine", "--dataset", str(root), "--split", "test", "--init", str(root / "init.csv"),
               "--out", str(out), "--max-iters", "3"])
    assert rc == 0
    csvs = list(out.glob("*.csv"))
    assert len(csvs) == 1
    est = read_bop19_csv(csvs[0])
    assert len(est) == len(gt)
    err0 = np.mean([np.linalg.norm(init[k][:3, 3] - gt[k][:3, 3]) for k in gt])
    err1 = np.mean([np.linalg.norm(e.T_m2c[:3, 3] - gt[(e.im_id, e.obj_id)][:3, 3]) for e in est])
    assert err1 < err0 / 2, (err0, err1)
    sg = read_scene_gt(out / "test" / "000001" / "scene_gt.json")
    cams = read_scene_camera(out / "test" / "000001" / "scene_camera.json")
    assert len(sg) == 4 and all(len(v) == 5 for v in sg.values())
    raw = json.loads((out / "test" / "000001" / "scene_camera.json").read_text())
    assert np.allclose(np.array(raw["0"]["cam_R_w2c"]).reshape(3, 3), np.eye(3)) and len(cams) == 4
    sig = json.loads((out / "refine" / "000001_sigma.json").read_text())
    assert len(sig["objects"]) == 5 and len(sig["poses"]) == 20
    assert all(0 < max(v["sigma_t_mm"]) < 20 for v in sig["objects"].values())
    log = json.loads((out / "refine" / "000001_log.json").read_text())
    assert len(log["log"]) > 3 and "total_s" in log["stats"]
    world = json.loads((out / "refine" / "000001_world.json").read_text())
    assert len(world["T_m2w"]) == 5
    status = json.loads((out / "refine" / "000001_status.json").read_text())
    assert [v["im_id"] for v in status["views"]] == sorted({k[0] for k in gt})
    assert all(v["shift_px"] is not None and 0.0 <= v["shift_px"] <= 16.0 for v in status["views"])
    assert len(status["poses"]) == 20


def test_cli_refine_bad_init_is_one_line_error(bop_root, tmp_path, capsys):
    root, _, _ = bop_root
    rc = main(["refine", "--dataset", str(root), "--split", "test", "--init", str(tmp_path / "nope.csv"),
               "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "nope.csv" in err[0]


def test_cli_refine_known_cameras_keeps_the_given_cameras(bop_root, tmp_path):
    """--known-cameras: the written cameras are scene_camera.json's (relative to the first frame),
    and the objects are still refined."""
    from ycbvss.geometry.se3 import inv_T
    from ycbvss.io.bop import read_scene_camera
    from ycbvss.io.results import read_bop19_csv

    root, init, gt = bop_root
    out = tmp_path / "out"
    rc = main(["refine", "--dataset", str(root), "--split", "test", "--init", str(root / "init.csv"),
               "--out", str(out), "--max-iters", "3", "--known-cameras"])
    assert rc == 0
    given = read_scene_camera(root / "test" / "000001" / "scene_camera.json")
    got = read_scene_camera(out / "test" / "000001" / "scene_camera.json")
    g0, w0 = inv_T(given[0]["T_w2c"]), inv_T(got[0]["T_w2c"])
    for im in given:
        rel_given, rel_got = given[im]["T_w2c"] @ g0, got[im]["T_w2c"] @ w0
        assert np.abs(rel_given[:3, 3] - rel_got[:3, 3]).max() < 1e-6    # mm
        assert np.abs(rel_given[:3, :3] - rel_got[:3, :3]).max() < 1e-9
    est = read_bop19_csv(next(out.glob("*.csv")))
    err0 = np.mean([np.linalg.norm(init[k][:3, 3] - gt[k][:3, 3]) for k in gt])
    err1 = np.mean([np.linalg.norm(e.T_m2c[:3, 3] - gt[(e.im_id, e.obj_id)][:3, 3]) for e in est])
    assert err1 < err0 / 2, (err0, err1)


def test_cli_refine_known_cameras_without_them_is_one_line_error(bop_root, tmp_path, capsys):
    import shutil

    root, _, _ = bop_root
    bare = tmp_path / "bare"
    shutil.copytree(root, bare)
    p = bare / "test" / "000001" / "scene_camera.json"
    cams = json.loads(p.read_text())
    for v in cams.values():
        v.pop("cam_R_w2c"), v.pop("cam_t_w2c")
    p.write_text(json.dumps(cams))
    rc = main(["refine", "--dataset", str(bare), "--split", "test", "--init", str(bare / "init.csv"),
               "--out", str(tmp_path / "o"), "--known-cameras"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and "T_w2c" in err[0] and "scene 1" in err[0], err


def test_cli_refine_contact_options_refine_and_a_bad_one_is_one_line_error(bop_root, tmp_path, capsys):
    from ycbvss.io.results import read_bop19_csv

    root, init, gt = bop_root
    out = tmp_path / "out"
    rc = main(["refine", "--dataset", str(root), "--split", "test", "--init", str(root / "init.csv"),
               "--out", str(out), "--max-iters", "3", "--edge-contact-mm", "10", "--contact-weight", "1"])
    assert rc == 0
    est = read_bop19_csv(next(out.glob("*.csv")))
    err0 = np.mean([np.linalg.norm(init[k][:3, 3] - gt[k][:3, 3]) for k in gt])
    err1 = np.mean([np.linalg.norm(e.T_m2c[:3, 3] - gt[(e.im_id, e.obj_id)][:3, 3]) for e in est])
    assert err1 < err0 / 2, (err0, err1)
    capsys.readouterr()
    rc = main(["refine", "--dataset", str(root), "--split", "test", "--init", str(root / "init.csv"),
               "--out", str(tmp_path / "o2"), "--contact-weight", "-1"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and "contact_weight" in err[0] and "scene 1" in err[0], err


def test_cli_refine_table_flow_refines(bop_root, tmp_path):
    from ycbvss.io.results import read_bop19_csv

    root, init, gt = bop_root
    out = tmp_path / "out"
    rc = main(["refine", "--dataset", str(root), "--split", "test", "--init", str(root / "init.csv"),
               "--out", str(out), "--max-iters", "3", "--table-flow", "--table-span-deg", "30"])
    assert rc == 0
    est = read_bop19_csv(next(out.glob("*.csv")))
    err0 = np.mean([np.linalg.norm(init[k][:3, 3] - gt[k][:3, 3]) for k in gt])
    err1 = np.mean([np.linalg.norm(e.T_m2c[:3, 3] - gt[(e.im_id, e.obj_id)][:3, 3]) for e in est])
    assert err1 < err0 / 2, (err0, err1)


def test_cli_refine_no_table_contact_is_parsed_to_the_option():
    from ycbvss.cli import build_parser
    p = build_parser()
    base = ["refine", "--dataset", "d", "--out", "o", "--init", "i"]
    assert p.parse_args(base + ["--no-table-contact"]).table_contact is False
    assert p.parse_args(base).table_contact is None          # None: RefineOptions' default (held)
    assert p.parse_args(base + ["--table-contact", "narrow,medium"]).table_contact == "narrow,medium"


def test_cli_refine_bad_edge_junction_px_is_one_line_error(bop_root, tmp_path, capsys):
    root, _, _ = bop_root
    rc = main(["refine", "--dataset", str(root), "--split", "test", "--init", str(root / "init.csv"),
               "--out", str(tmp_path / "o"), "--edge-junction-px", "-2"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and "edge_junction_px" in err[0] and "scene 1" in err[0], err


def test_cli_refine_options_reach_the_refiner_and_bad_ones_are_one_line_errors(bop_root, tmp_path, capsys):
    """``--options`` sets RefineOptions fields (inline or from a file): a value only the refiner
    checks fails there with its scene named, so it got through; a misspelt field or bad JSON stops
    before anything runs, with one line naming the field or the file."""
    root, _, _ = bop_root
    base = ["refine", "--dataset", str(root), "--split", "test", "--init", str(root / "init.csv")]
    rc = main(base + ["--out", str(tmp_path / "o1"), "--options", '{"interior_turn_groups": "wdie"}'])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and "interior_turn_groups" in err[0] and "scene 1" in err[0], err
    rc = main(base + ["--out", str(tmp_path / "o2"), "--options", '{"max_iter": 2}'])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and "'max_iter'" in err[0] and "did you mean 'max_iters'" in err[0], err
    assert not (tmp_path / "o2").exists()
    bad = tmp_path / "opts.json"
    bad.write_text('{"alpha": 2,}')
    rc = main(base + ["--out", str(tmp_path / "o3"), "--options", f"@{bad}"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and str(bad) in err[0] and "not valid JSON" in err[0], err
    good = tmp_path / "good.json"
    good.write_text('{"max_iters": 2, "coarse_iters": 1, "edge_sigmas_px": [4, 2, 1]}')
    rc = main(base + ["--out", str(tmp_path / "o4"), "--options", str(good)])
    assert rc == 0 and any((tmp_path / "o4").glob("*.csv"))


def test_cli_validate_bad_options_is_one_line_error_before_anything_runs(bop_root, tmp_path, capsys):
    root, _, _ = bop_root
    rc = main(["validate", "--gt-exact", "--dataset", str(root), "--out", str(tmp_path / "v"),
               "--options", '{"use_edge": "no"}'])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and "RefineOptions.use_edge" in err[0], err
    assert not (tmp_path / "v").exists()
