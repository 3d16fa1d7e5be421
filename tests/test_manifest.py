"""assets_manifest.yaml: objects, cameras, sample-data sums and `assets verify`.

Budget: ~3 s.
"""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

from ycbvss.errors import YcbvssError
from ycbvss.manifest import (MANIFEST_PATH, bop_symmetries, camera_for_video, load_manifest, object_entries,
                             object_names, protocol_symmetric_ids, verify_assets)

PAPER_TEXTURELESS = {"011_banana", "019_pitcher_base", "024_bowl", "025_mug", "037_scissors",
                     "051_large_clamp", "052_extra_large_clamp", "061_foam_brick"}


def test_manifest_is_the_top_level_file():
    # editable installs resolve to the file itself, wheel installs carry a byte-identical copy
    top = Path(__file__).resolve().parents[1] / "assets_manifest.yaml"
    assert MANIFEST_PATH.read_bytes() == top.read_bytes()


def test_objects_match_classes_txt_and_paper_flags(ycbv_root):
    classes = (ycbv_root / "image_sets" / "classes.txt").read_text().split()
    names = object_names()
    assert [names[i] for i in range(1, 22)] == classes
    ent = object_entries()
    assert {e["name"] for e in ent.values() if e["textureless"]} == PAPER_TEXTURELESS
    assert protocol_symmetric_ids() == (13,)
    assert "reconstruction error" in ent[16].get("note", "")


def test_bop_symmetries_are_rigid_and_centred():
    n_with = 0
    for oid in range(1, 22):
        disc, cont = bop_symmetries(oid)
        n_with += bool(disc or cont)
        for S in disc:
            assert np.abs(S[:3, :3].T @ S[:3, :3] - np.eye(3)).max() < 1e-12
            assert abs(np.linalg.det(S[:3, :3]) - 1) < 1e-12 and np.abs(S[:3, 3]).max() == 0
        for c in cont:
            assert abs(np.linalg.norm(c["axis"]) - 1) < 1e-12
    # cans (1, 4, 6) and the bowl (13) have a continuous axis; the mug (14) and drill (15) none
    for oid in (1, 4, 6, 13):
        assert bop_symmetries(oid)[1], oid
    for oid in (14, 15):
        assert bop_symmetries(oid) == ([], []), oid
    assert 10 <= n_with <= 16


def test_cameras_match_calibration_files_and_meta(ycbv_root):
    import scipy.io
    for name, video in (("uw", 0), ("cmu", 60)):
        cam_name, K = camera_for_video(video)
        assert cam_name == name
        params = json.loads((ycbv_root / "cameras" / f"asus-{name}.json").read_text())[
            "rig"]["camera"][0]["camera_model"]["params"]
        assert np.allclose([K[0, 0], K[1, 1], K[0, 2], K[1, 2]], params[:4], atol=0, rtol=0)
    assert camera_for_video(59)[0] == "uw" and camera_for_video(91)[0] == "cmu"
    meta = scipy.io.loadmat(str(ycbv_root / "data/0000/000001-meta.mat"))
    assert np.abs(meta["intrinsic_matrix"] - camera_for_video(0)[1]).max() < 1e-9
    with pytest.raises(YcbvssError, match="no YCB-Video camera for video 0092"):
        camera_for_video(92)


def test_verify_shared_data_all_ok(shared_data):
    res = verify_assets(shared_data)
    files = sorted(p.relative_to(shared_data).as_posix() for p in shared_data.rglob("*") if p.is_file())
    assert sorted(r for r, _ in res) == files            # every file under shared/data is recorded
    assert {s for _, s in res} == {"OK"}


def test_verify_reports_missing_and_mismatch(shared_data, tmp_path):
    m = load_manifest()
    sub = {k: v for k, v in m["sample_data"]["files"].items() if k.startswith("ycbv/image_sets/")}
    local = tmp_path / "copy"
    for rel in sub:
        (local / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(shared_data / rel, local / rel)
    (local / "ycbv/image_sets/classes.txt").write_text("tampered\n")
    (local / "ycbv/image_sets/keyframe.txt").unlink()
    man = {**m, "sample_data": {"files": {**sub, "ycbv/not_there.txt": "0" * 64}}}
    res = dict(verify_assets(local, man))
    assert res == {"ycbv/image_sets/classes.txt": "mismatch", "ycbv/image_sets/keyframe.txt": "missing",
                   "ycbv/not_there.txt": "missing"}
    # via the CLI: exit 1, per-file lines
    from ycbvss.cli import main
    mp = tmp_path / "m.yaml"
    mp.write_text(yaml.safe_dump(man))
    assert main(["assets", "verify", "--root", str(local), "--manifest", str(mp)]) == 1


def test_malformed_manifest_is_one_error(tmp_path, capsys):
    from ycbvss.cli import main
    bad = tmp_path / "bad.yaml"
    bad.write_text("objects: [\n  - {obj_id: 1\n")
    assert main(["assets", "verify", "--root", str(tmp_path), "--manifest", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bad.yaml" in err[0] and "malformed YAML" in err[0]
