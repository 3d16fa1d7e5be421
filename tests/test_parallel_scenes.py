"""Whole-dataset runs: `ycbvss refine --workers 2` (spawned processes) gives the same poses as one worker,
re-running resumes per scene, an unwritable --out fails before any work. Budget ~40 s."""
from __future__ import annotations

import numpy as np
import pytest

from ycbvss.cli import main


@pytest.fixture(scope="module")
def two_scenes(tmp_path_factory):
    from ycbvss.io.bop import BopSceneWriter
    from ycbvss.procedural.io import write_models
    from ycbvss.procedural.render import render_frame_fast
    from ycbvss.procedural.scene import make_scene
    root = tmp_path_factory.mktemp("bop2")
    for sid, seed in ((1, 1), (2, 2)):
        ps = make_scene(seed=seed, n_frames=3, width=320, height=240, arc_deg=30)
        if sid == 1:
            write_models(ps, root / "models")
        with BopSceneWriter(root / "test", sid) as w:
            for f in ps.frames:
                w.write_frame(f, rgb=render_frame_fast(ps, f, noise_sigma=1.0)[0])
    return root


def _poses(csv):
    from ycbvss.io.results import read_bop19_csv
    return {(e.scene_id, e.im_id, e.obj_id): e.T_m2c for e in read_bop19_csv(csv)}


def test_two_workers_resume_and_unwritable_out(two_scenes, tmp_path, capsys):
    root = two_scenes
    args = ["refine", "--dataset", str(root), "--split", "test", "--init", "scene_gt", "--max-iters", "2"]
    assert main(args + ["--out", str(tmp_path / "w1"), "--scenes", "1-2"]) == 0
    assert main(args + ["--out", str(tmp_path / "w2"), "--workers", "2"]) == 0
    p1, p2 = _poses(tmp_path / "w1" / f"refine_{root.name}-test.csv"), _poses(tmp_path / "w2" / f"refine_{root.name}-test.csv")
    assert sorted(p1) == sorted(p2) and {k[0] for k in p1} == {1, 2}
    diff = max(np.abs(p1[k] - p2[k]).max() for k in p1)
    assert diff < 1e-3, diff                       # same per-scene computation in another process (mm / rotation)
    # resume: scene 2's done marker removed -> only scene 2 is refined again
    (tmp_path / "w2" / "refine" / "000002_estimates.csv").unlink()
    capsys.readouterr()
    assert main(args + ["--out", str(tmp_path / "w2"), "--workers", "2"]) == 0
    out = capsys.readouterr().out
    assert "1 scene(s) already refined" in out and "scene 2:" in out and "scene 1:" not in out, out
    assert sorted(_poses(tmp_path / "w2" / f"refine_{root.name}-test.csv")) == sorted(p1)
    # unwritable --out (a file) -> one error line, exit 2, before any refinement
    blocker = tmp_path / "file"
    blocker.write_text("x")
    rc = main(args + ["--out", str(blocker / "sub")])
    cap = capsys.readouterr()
    assert rc == 2 and "not writable" in cap.err and "scene 1:" not in cap.out
