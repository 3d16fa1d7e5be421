"""The capture-range levels: init modes add<N> / prj<N> reach their targets, and the report
draws one curve per axis (pure: synthetic poses and rows, no rendering)."""
from __future__ import annotations

import numpy as np
import pytest

from ycbvss.pipeline.suite import Clip
from ycbvss.pipeline.suite_report import capture_png, capture_table
from ycbvss.pipeline.suite_run import CAPTURE_PRJ_LEVELS, Run, init_targets, initial_poses

K = np.array([[1066.8, 0.0, 313.0], [0.0, 1067.5, 241.3], [0.0, 0.0, 1.0]])


def _scene(seed: int = 1):
    rng = np.random.default_rng(seed)
    pts = {o: rng.uniform(-r, r, (400, 3)) * (1.0, 0.6, 1.4) for o, r in ((1, 30.0), (2, 60.0), (3, 90.0))}
    gt, Ks = {}, {}
    for v in range(6):
        for o in pts:
            T = np.eye(4)
            T[:3, 3] = (rng.uniform(-150, 150), rng.uniform(-100, 100), rng.uniform(500, 1500))
            gt[(v, o)], Ks[(v, o)] = T, K
    return gt, Ks, pts


@pytest.mark.parametrize("level", CAPTURE_PRJ_LEVELS)
def test_prj_levels_hold_the_papers_depth_error_and_reach_their_prj(level):
    from ycbvss.eval.metrics import prj_px
    gt, Ks, pts = _scene()
    clip = Clip(1, "short", tuple(range(6)), False)
    paper = initial_poses(Run(clip, "paper", 0), gt, Ks, pts)
    init = initial_poses(Run(clip, level, 0), gt, Ks, pts)
    target = init_targets(level)[1]
    keys = sorted(gt)
    prj = [prj_px(init[k][None, :3, :3], init[k][None, :3, 3], gt[k][None, :3, :3], gt[k][None, :3, 3],
                  K[None], pts[k[1]])[0] for k in keys]
    assert abs(np.mean(prj) / target - 1) < 0.005
    # the same draws: the depth (along-ray) part of every deviation is the paper init's
    for k in keys:
        ray = gt[k][:3, 3] / np.linalg.norm(gt[k][:3, 3])
        assert (init[k][:3, 3] - gt[k][:3, 3]) @ ray == pytest.approx((paper[k][:3, 3] - gt[k][:3, 3]) @ ray, abs=1e-6)


def test_prj_level_at_the_papers_prj_is_the_papers_init():
    gt, Ks, pts = _scene(2)
    clip = Clip(1, "short", tuple(range(6)), False)
    a = initial_poses(Run(clip, "paper", 3), gt, Ks, pts)
    b = initial_poses(Run(clip, "prj5.2", 3), gt, Ks, pts)
    assert max(np.abs(a[k] - b[k]).max() for k in gt) < 0.05


def _rows(init, add, prj, shares):
    out = []
    for kind, share in shares.items():
        n_ok = int(round(share * 20))
        for i in range(20):
            out.append({"clip": f"{kind}-1", "kind": kind, "init": init, "variant": "using all",
                        "init_add_mm": add, "init_prj_px": prj, "add_mm": 1.0 if i < n_ok else 30.0})
    return out


def test_capture_table_has_one_curve_per_axis_with_the_paper_on_both(tmp_path):
    rows = (_rows("add5", 5.0, 1.2, {"short": 0.9, "long": 1.0}) + _rows("add40", 40.0, 9.4, {"short": 0.5, "long": 0.8})
            + _rows("paper", 22.1, 5.2, {"short": 0.7, "long": 0.95})
            + _rows("prj2", 22.1, 2.0, {"short": 0.75, "long": 1.0}) + _rows("prj20", 22.1, 20.0, {"short": 0.2, "long": 0.4}))
    t, curves = capture_table(rows)
    assert [r.label for r in t.rows] == ["add5", "paper", "add40", "prj2", "prj20"]
    assert sorted(curves) == ["add", "prj"]
    assert [p[2] for p in curves["add"]["short"]] == pytest.approx([0.9, 0.7, 0.5])
    assert [p[1] for p in curves["prj"]["long"]] == pytest.approx([5.2, 2.0, 20.0])
    assert [p[2] for p in sorted(curves["prj"]["long"], key=lambda p: p[1])] == pytest.approx([1.0, 0.95, 0.4])
    png = capture_png(curves, tmp_path / "capture.png")
    assert png.stat().st_size > 10_000


def test_unknown_init_mode_is_one_clear_error():
    from ycbvss.errors import YcbvssError
    with pytest.raises(YcbvssError, match="prj<px>"):
        init_targets("deg5")
