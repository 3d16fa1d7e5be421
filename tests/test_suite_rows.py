"""Rows of the validation suite: the model-frame rotation error, appending to an older rows file, reading a gzipped one; a clip named wrongly."""
from __future__ import annotations

import csv

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ycbvss.eval.metrics import pose_errors
from ycbvss.pipeline import suite_run
from ycbvss.pipeline.suite_run import ROW_FIELDS, rotation_error_in_model_deg


def test_model_frame_error_names_the_axis_and_matches_r_deg():
    rng = np.random.default_rng(3)
    R_gt = Rotation.random(random_state=4).as_matrix()
    roll = Rotation.from_rotvec([0.0, 0.0, 0.5], degrees=True).as_matrix()      # about the model's own z
    w = rotation_error_in_model_deg(R_gt @ roll, R_gt)
    assert np.allclose(w, (0.0, 0.0, 0.5), atol=1e-9)
    # any error: its norm is the metric's R error
    d = Rotation.from_rotvec(rng.normal(size=3) * 0.01).as_matrix()
    w = rotation_error_in_model_deg(R_gt @ d, R_gt)
    K = np.array([[1000.0, 0, 320], [0, 1000, 240], [0, 0, 1]])
    E = pose_errors((R_gt @ d)[None], np.array([[0, 0, 800.0]]), R_gt[None], np.array([[0, 0, 800.0]]),
                    K[None], rng.normal(size=(50, 3)) * 30)
    assert abs(np.linalg.norm(w) - float(E["r_deg"][0])) < 1e-6


def test_resumed_run_appends_in_the_old_files_columns(tmp_path, monkeypatch):
    old = [f for f in ROW_FIELDS if not f.startswith(("rx_", "ry_", "rz_"))]
    assert len(old) == len(ROW_FIELDS) - 3
    rows_path = tmp_path / "rows.csv"
    with open(rows_path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=old)
        w.writeheader()
        w.writerow({f: "1" for f in old})
    row = {f: "2" for f in ROW_FIELDS}

    class _Clip:
        scene_id, name = 1, "short-1"

    class _Run:
        clip, key = _Clip(), "short-1_paper_s0_usingall"

    monkeypatch.setattr(suite_run, "load_bop_scene", lambda *a, **k: None)
    monkeypatch.setattr(suite_run, "run_one", lambda *a, **k: [row])
    suite_run.execute([_Run()], tmp_path / "root", {}, tmp_path)
    got = list(csv.DictReader(open(rows_path)))
    assert list(got[1].keys()) == old and all(v == "2" for v in got[1].values())
    assert len(suite_run.read_rows(rows_path)) == 2


def test_load_clip_names_a_bad_clip_name_before_building_anything(tmp_path):
    import pytest

    from ycbvss.errors import YcbvssError
    from ycbvss.pipeline.suite import load_clip

    with pytest.raises(YcbvssError, match="medium"):
        load_clip(tmp_path / "no-dataset", tmp_path / "suite", "medium")
    assert not (tmp_path / "suite").exists()


def test_restart_flags_keep_the_first_pass_fallback_when_a_restart_is_kept():
    """A put-back object makes the scene restart; the kept restart's own stats hold no fallback, so
    the row flags take it from the restart note (suite medium-1 seed 5, session 49: the large clamp)."""
    from ycbvss.pipeline.suite_run import restart_flags

    kept = {"ridge_fallback": [], "slide_restart": {"objects": [19], "ridge_fallback": [[19]], "kept": True}}
    assert restart_flags(kept) == ({19}, {19})
    dropped = {"ridge_fallback": [[21]], "slide_restart": {"objects": [21], "ridge_fallback": [[21]], "kept": False}}
    assert restart_flags(dropped) == ({21}, set())
    assert restart_flags({}) == (set(), set())


def test_read_rows_reads_a_gzipped_rows_file_as_the_plain_one(tmp_path):
    import gzip

    rows_path = tmp_path / "rows.csv"
    with open(rows_path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=ROW_FIELDS)
        w.writeheader()
        w.writerow({f: ("converged" if f == "status" else "3") for f in ROW_FIELDS})
    with open(rows_path, "rb") as src, gzip.open(tmp_path / "rows.csv.gz", "wb") as dst:
        dst.write(src.read())
    plain, packed = suite_run.read_rows(rows_path), suite_run.read_rows(tmp_path / "rows.csv.gz")
    assert packed == plain and plain[0]["obj_id"] == 3 and plain[0]["tz_mm"] == 3.0


def test_suite_runs_record_their_host_options_and_images(tmp_path, monkeypatch):
    """``execute`` writes provenance.json beside rows.csv: per call the refining host, the options
    and the runs; per scene the digest of its images on disk and what its marker recorded."""
    import json

    from ycbvss.io.provenance import rgb_sha256

    sdir = tmp_path / "root" / "test" / "000001"
    (sdir / "rgb").mkdir(parents=True)
    (sdir / "rgb" / "000000.png").write_bytes(b"image bytes")
    digest = rgb_sha256(sdir)
    (sdir / "suite_scene.json").write_text(json.dumps({"hash": "h1", "rgb_sha256": digest,
                                                       "rendered_on": {"cpu": "renderer CPU"}}))

    class _Clip:
        scene_id, name = 1, "short-1"

    class _Run:
        clip, key = _Clip(), "short-1_paper_s0_usingall"

    monkeypatch.setattr(suite_run, "load_bop_scene", lambda *a, **k: None)
    monkeypatch.setattr(suite_run, "run_one", lambda *a, **k: [{f: "1" for f in ROW_FIELDS}])
    suite_run.execute([_Run()], tmp_path / "root", {}, tmp_path / "work", {"alpha": 4})
    suite_run.execute([_Run()], tmp_path / "root", {}, tmp_path / "work", {"alpha": 4})   # resumed: nothing to run
    prov = json.loads((tmp_path / "work" / "provenance.json").read_text())
    assert [e["options"] for e in prov["refined_on"]] == [{"alpha": 4}, {"alpha": 4}]
    assert prov["refined_on"][0]["runs"] == ["short-1_paper_s0_usingall"] and prov["refined_on"][0]["host"]["cpu"]
    assert prov["refined_on"][1]["runs"] == []                                     # the resumed call refined nothing
    assert prov["scenes"]["1"] == {"rgb_sha256": digest, "marker_rgb_sha256": digest,
                                   "rendered_on": {"cpu": "renderer CPU"}, "hash": "h1"}
    (sdir / "rgb" / "000000.png").write_bytes(b"other bytes")                   # the images changed on disk
    assert suite_run.scene_provenance(tmp_path / "root", [1])["1"]["rgb_sha256"] != digest


def test_resuming_with_other_refiner_options_is_refused(tmp_path, monkeypatch):
    """Rows refined with one set of options are never mixed with, or reported as, another's: a
    call whose done runs were refined with other options stops with one error naming the folder
    and both option sets, before it writes anything."""
    from ycbvss.errors import YcbvssError
    from ycbvss.refine.matching import FlowOptions

    class _Clip:
        scene_id, name = 1, "short-1"

    class _Run:
        def __init__(self, key):
            self.clip, self.key = _Clip(), key

    monkeypatch.setattr(suite_run, "load_bop_scene", lambda *a, **k: None)
    monkeypatch.setattr(suite_run, "scene_provenance", lambda *a, **k: {})
    monkeypatch.setattr(suite_run, "run_one", lambda *a, **k: [{f: "1" for f in ROW_FIELDS}])
    work = tmp_path / "work"
    suite_run.execute([_Run("a")], tmp_path / "root", {}, work, {"flow": FlowOptions(winsize=15)})
    rows_before = (work / "rows.csv").read_text()
    prov_before = (work / "provenance.json").read_text()
    with pytest.raises(YcbvssError, match="refined with the options") as e:
        suite_run.execute([_Run("a"), _Run("b")], tmp_path / "root", {}, work, {"alpha": 4})
    assert str(work) in str(e.value) and '"winsize": 15' in str(e.value) and '"alpha": 4' in str(e.value)
    assert (work / "rows.csv").read_text() == rows_before and (work / "provenance.json").read_text() == prov_before
    # the same options resume: only the missing run is refined
    suite_run.execute([_Run("a"), _Run("b")], tmp_path / "root", {}, work, {"flow": FlowOptions(winsize=15)})
    assert len(suite_run.read_rows(work / "rows.csv")) == 2
