"""The validate loop on a tiny procedural demo (fast renderer), output files, CLI errors, and one
`ycbvss demo --quick` through the CLI. Budget: < 3 min on 2 cores (two refinement loops)."""
from __future__ import annotations

import csv
import os
import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from ycbvss.pipeline.perturb import perturb_poses
from ycbvss.procedural import make_scene


# ----------------------------------------------------------------------------- perturbation
def _gt(scene):
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in scene.frames for i in f.instances}
    Ks = {k: scene.frames[k[0]].camera.K for k in gt}
    pts = {o: np.asarray(m.mesh.vertices) for o, m in scene.models.items()}
    return gt, Ks, pts


def test_perturbation_hits_targets_and_is_pure():
    sc = make_scene(seed=2, n_frames=8)
    gt, Ks, pts = _gt(sc)
    for add, prj in ((22.1, 5.2), (10.0, 2.0), (40.0, 9.0)):
        r = perturb_poses(gt, Ks, pts, add, prj, seed=3)
        assert r.converged
        assert abs(r.add_mm / add - 1) < 0.01 and abs(r.prj_px / prj - 1) < 0.01, r.summary()
    a = perturb_poses(gt, Ks, pts, seed=4)
    b = perturb_poses(gt, Ks, pts, seed=4)
    c = perturb_poses(gt, Ks, pts, seed=5)
    k = next(iter(gt))
    np.testing.assert_array_equal(a.poses[k], b.poses[k])
    assert np.abs(a.poses[k] - c.poses[k]).max() > 1e-3
    # the error is mostly along the line of sight (as YCB-V's): mean |dz| >= 3 x mean lateral
    d = np.array([a.poses[k][:3, 3] - gt[k][:3, 3] for k in gt])
    assert np.abs(d[:, 2]).mean() > 3 * np.abs(d[:, :2]).mean()
    # independent per (view, object): deviations of one object in consecutive views are uncorrelated
    dz = np.array([[a.poses[(i, o)][2, 3] - gt[(i, o)][2, 3] for i in range(8)] for o in sc.models])
    assert abs(np.corrcoef(dz[:, :-1].ravel(), dz[:, 1:].ravel())[0, 1]) < 0.6


# ----------------------------------------------------------------------------- the loop
@pytest.fixture(scope="module")
def demo_run(tmp_path_factory):
    from ycbvss.pipeline.demo import DemoOptions, run_demo
    from ycbvss.pipeline.validate import Stages
    out = tmp_path_factory.mktemp("demo_fast")
    os.environ["YCBVSS_NO_PROGRESS"] = "1"
    summary = run_demo(DemoOptions(out=out, frames=6, width=320, renderer="fast", ablation=False, overlays=2),
                       Stages(quiet=True))
    return out, summary


def test_refined_errors_far_below_initial(demo_run):
    _, s = demo_run
    init, ref = s["initial"], s["refined"]
    # calibration: achieved initial errors within 1 % of the (resolution-scaled) targets
    assert abs(init["achieved_add_mm"] / 22.1 - 1) < 0.01
    assert abs(init["achieved_prj_px"] / (5.2 * 320 / 640) - 1) < 0.01
    # stated bounds: refined mean PRJ < 0.3 x initial, refined mean ADD < 0.25 x initial
    assert ref["prj_px"] < 0.3 * init["prj_px"], (ref, init)
    assert ref["add_mm"] < 0.25 * init["add_mm"], (ref, init)


def test_every_table_exists_and_parses(demo_run):
    out, _ = demo_run
    for stem in ("table4", "summary"):
        rows = list(csv.reader(open(out / "tables" / f"{stem}.csv", newline="")))
        assert len(rows) >= 3 and all(len(r) == len(rows[0]) for r in rows)
        md = (out / "tables" / f"{stem}.md").read_text()
        assert re.search(r"^\|.*\|\s*$", md, re.M) and "---" in md
        tex = (out / "tables" / f"{stem}.tex").read_text()
        assert "\\begin{tabular}" in tex and "\\end{tabular}" in tex
    rows = list(csv.reader(open(out / "tables" / "table4.csv", newline="")))
    assert rows[0][1:6] == ["tx (mm)", "ty (mm)", "tz (mm)", "R (deg)", "PRJ (px)"]
    labels = [r[0] for r in rows[1:]]
    assert labels[:5] == ["box_checker", "box_plain", "can_stripes", "can_text", "mug_plain"]
    assert {"all", "initial", "paper (Li et al.) all", "YCBV original (paper)"} <= set(labels)
    tl = {r[0]: r[-1] for r in rows[1:]}
    assert tl["box_plain"] == "1" and tl["mug_plain"] == "1" and tl["box_checker"] == "0"
    # the poses files are valid BOP19 CSVs with one row per (view, object)
    from ycbvss.io.results import read_bop19_csv
    ests = read_bop19_csv(out / "poses" / "refined_poses.csv")
    assert len(ests) == 6 * 5


def test_refined_poses_carry_the_refiners_status_and_confidence(demo_run):
    """The BOP19 score of every refined pose is the refiner's confidence, not 1 (issue 9, section 5):
    the per-object mean of the CSV's scores equals tables/status.csv's mean confidence, the statuses
    cover every pose, and every pose > 10 mm ADD from the exact GT is flagged."""
    from ycbvss.io.results import read_bop19_csv
    out, s = demo_run
    ests = read_bop19_csv(out / "poses" / "refined_poses.csv")
    scores = np.array([e.score for e in ests])
    assert np.all((scores >= 0.0) & (scores <= 1.0))
    assert scores.max() < 1.0                          # a confidence, never the placeholder 1
    rows = list(csv.DictReader(open(out / "tables" / "status.csv", newline="")))
    by_label = {r[next(iter(r))]: r for r in rows}
    assert int(float(by_label["all"]["poses"])) == len(ests) == sum(s["status"].values())
    names = {1: "box_checker", 2: "box_plain", 3: "can_stripes", 4: "can_text", 5: "mug_plain"}
    for oid, name in names.items():
        sc = [e.score for e in ests if e.obj_id == oid]
        assert abs(np.mean(sc) - float(by_label[name]["mean confidence"])) < 1e-3, name
    assert by_label["all"]["of those flagged"] == by_label["all"]["ADD > 10 mm"]


def test_quick_demo_seed_9_flags_the_mug_turned_about_its_hidden_handle(tmp_path):
    """`ycbvss demo --quick --renderer fast --no-ablation --seed 9`: the plain mug's handle is hidden in
    all 6 views and it ends about 17 deg off about its axis (ADD about 11 mm). Session 93 found 4 of its 6
    poses `converged` (sigma_ADD 1.7-1.9 mm); the silhouette turn check (refine.turn_check) makes every
    pose > 10 mm `uncertain` or `failed`. Fast-rendered images: a status test, not accuracy evidence."""
    from ycbvss.pipeline.demo import DemoOptions, run_demo
    from ycbvss.pipeline.validate import Stages
    os.environ["YCBVSS_NO_PROGRESS"] = "1"
    out = tmp_path / "demo9"
    run_demo(DemoOptions(out=out, frames=6, width=320, renderer="fast", ablation=False, overlays=0, seed=9),
             Stages(quiet=True))
    rows = {r[next(iter(r))]: r for r in csv.DictReader(open(out / "tables" / "status.csv", newline=""))}
    far = int(rows["all"]["ADD > 10 mm"])
    assert far >= 1                                        # the case is still there to be flagged
    assert int(rows["all"]["of those flagged"]) == far
    assert int(rows["mug_plain"]["converged"]) == 0


class _Refs(HTMLParser):
    def __init__(self):
        super().__init__()
        self.refs = []

    def handle_starttag(self, tag, attrs):
        for k, v in attrs:
            if k in ("href", "src") and v is not None:
                self.refs.append(v)


def test_html_report_references_existing_files(demo_run):
    out, s = demo_run
    page = Path(s["report"])
    assert page == out / "report.html"
    p = _Refs()
    p.feed(page.read_text())
    local = [r for r in p.refs if not r.startswith("data:")]
    inlined = [r for r in p.refs if r.startswith("data:image/png;base64,")]
    assert len(inlined) >= 3                                # curves + 2 overlays inlined
    assert len(local) >= 8
    for r in local:
        assert not r.startswith(("/", "http")), r           # relative links only
        assert (page.parent / r).is_file(), r


def _cli(*args, timeout=600):
    env = dict(os.environ, YCBVSS_NO_PROGRESS="1")
    return subprocess.run([sys.executable, "-m", "ycbvss.cli", *args], capture_output=True, text=True,
                          timeout=timeout, env=env)


@pytest.mark.parametrize("args,needle", [
    (["validate", "--dataset", "/nonexistent/ds", "--out", "OUT"], "dataset not found"),
    (["validate", "--dataset", "DATASET_FILE", "--out", "OUT"], "must be a folder"),
    (["validate", "--dataset", "EMPTY_DIR", "--out", "OUT"], "no BOP split folder"),
    (["validate", "--dataset", "EMPTY_DIR", "--out", "OUT", "--init-add-mm", "-3"], "positive number"),
    (["demo", "--out", "OUT", "--frames", "1"], "must be >= 2"),
    (["demo", "--out", "OUT", "--renderer", "povray"], "invalid choice"),
])
def test_bad_input_is_one_error_line(tmp_path, args, needle):
    (tmp_path / "empty").mkdir()
    (tmp_path / "file.txt").write_text("x")
    subst = {"OUT": str(tmp_path / "out"), "EMPTY_DIR": str(tmp_path / "empty"),
             "DATASET_FILE": str(tmp_path / "file.txt")}
    r = _cli(*[subst.get(a, a) for a in args], timeout=120)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("ycbvss") and "error:" in last and needle in last, r.stderr


def test_demo_quick_cli(tmp_path):
    """`ycbvss demo --quick` end to end through the CLI (Blender if importable, else the fast renderer)."""
    import importlib.util
    renderer = "blender" if importlib.util.find_spec("bpy") is not None else "fast"
    r = _cli("demo", "--quick", "--no-ablation", "--renderer", renderer, "--out", str(tmp_path / "d"), timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "| all |" in r.stdout and "report:" in r.stdout
    m = re.search(r"refined \(all terms\): mean ADD ([\d.]+) mm, mean PRJ ([\d.]+) px", r.stdout)
    i = re.search(r"initial poses: mean ADD ([\d.]+) mm .*mean PRJ ([\d.]+) px", r.stdout)
    assert m and i, r.stdout
    assert float(m.group(2)) < 0.3 * float(i.group(2))      # refined PRJ < 0.3 x initial
    assert (tmp_path / "d" / "report.html").is_file()


def test_validate_real_on_shared_ycbv(ycbv_root, tmp_path):
    """`validate --real` on 3 real YCB-Video frames: the original-vs-refined table and overlays."""
    out = tmp_path / "real"
    r = _cli("validate", "--real", "--dataset", str(ycbv_root), "--scenes", "0", "--max-frames", "3",
             "--frame-step", "4", "--overlays", "1", "--out", str(out), timeout=900)
    assert r.returncode == 0, r.stderr[-3000:]
    rows = list(csv.reader(open(out / "tables" / "original_vs_refined.csv", newline="")))
    labels = [row[0] for row in rows[1:]]
    assert labels[:3] == ["009_gelatin_box", "025_mug", "061_foam_brick"] and "all" in labels
    all_row = rows[1 + labels.index("all")]
    tz, prj = float(all_row[3]), float(all_row[5])
    # the refinement moves the annotations, but stays within the annotation error scale of YCB-V
    assert 0.0 < tz < 60.0 and 0.0 < prj < 20.0, all_row
    assert len(list((out / "figures").glob("overlay_*.png"))) == 1
    assert "original vs refined" in (out / "report.html").read_text()
