"""refine.interior_edges: interior edge candidates only where the surface is flat at the pixel scale."""
from __future__ import annotations

import numpy as np
import pytest

from ycbvss.refine.interior_edges import flat_at


def _rounded_edge_normals(w: int = 40, bevel_px: int = 4) -> np.ndarray:
    """A normal map (w, w, 3): a face looking at the camera for x < 16, then a bevel turning 90 deg
    over ``bevel_px`` pixels, then a face looking sideways."""
    ang = np.clip((np.arange(w) - 16) / bevel_px, 0.0, 1.0) * (np.pi / 2)
    n = np.stack([np.sin(ang), np.zeros(w), -np.cos(ang)], axis=1)
    return np.repeat(n[None], w, axis=0)


def test_flat_at_keeps_faces_and_drops_a_rounded_edge():
    n = _rounded_edge_normals()
    inst = np.ones(n.shape[:2], np.int32)
    uv = np.array([[5.0, 20.0], [17.0, 20.0], [18.0, 20.0], [30.0, 20.0]])
    keep = flat_at(n, inst, uv, max_turn_deg=20.0, radius_px=2)
    assert keep.tolist() == [True, False, False, True]


def test_flat_at_ignores_other_instances():
    n = _rounded_edge_normals()
    inst = np.ones(n.shape[:2], np.int32)
    inst[:, 16:] = 2                          # the bevel belongs to another object: no turn within object 1
    keep = flat_at(n, inst, np.array([[15.0, 20.0]]), max_turn_deg=20.0, radius_px=2)
    assert keep.tolist() == [True]


def test_flat_at_no_points():
    n = _rounded_edge_normals()
    assert flat_at(n, np.ones(n.shape[:2], np.int32), np.zeros((0, 2))).shape == (0,)


def test_interior_points_drop_texture_edges_on_a_rounded_edge_only():
    """A textured object with two colour steps: one on a flat face (x = 12), one on a bevel that
    turns 90 deg over 4 px (x = 30). With the limit, only the flat face's texture edge remains."""
    from ycbvss.refine.edge import all_interior_points

    H = W = 48
    inst = np.zeros((H, W), np.int32)
    inst[4:44, 4:44] = 1
    depth = np.where(inst > 0, 800.0, 0.0).astype(np.float32)
    color = np.full((H, W, 3), 60, np.uint8)
    color[:, 12:] = 140
    color[:, 30:] = 220
    ang = np.clip((np.arange(W) - 28) / 4.0, 0.0, 1.0) * (np.pi / 2)
    n = np.repeat(np.stack([np.sin(ang), np.zeros(W), -np.cos(ang)], axis=1)[None], H, axis=0)
    uv_all, _, _ = all_interior_points(inst, depth, color, None)
    uv_flat, _, _ = all_interior_points(inst, depth, color, None, texture_max_turn_deg=20.0, surface_normal=n)
    near = lambda uv, x: int(np.sum(np.abs(uv[:, 0] - x) < 2.0))
    assert near(uv_all, 11.5) > 20 and near(uv_all, 29.5) > 20          # both texture edges without the limit
    assert near(uv_flat, 11.5) == near(uv_all, 11.5) and near(uv_flat, 29.5) == 0



def test_interior_turn_gate_only_for_the_labels_given():
    """``texture_turn_labels``: the same bevelled step on two objects (rows 4-23 label 1, 24-43
    label 2); gating label 2 only drops label 2's texture edge on the bevel and keeps label 1's."""
    from ycbvss.refine.edge import all_interior_points

    H = W = 48
    inst = np.zeros((H, W), np.int32)
    inst[4:24, 4:44] = 1
    inst[24:44, 4:44] = 2
    depth = np.where(inst > 0, 800.0, 0.0).astype(np.float32)
    color = np.full((H, W, 3), 60, np.uint8)
    color[:, 30:] = 220
    ang = np.clip((np.arange(W) - 28) / 4.0, 0.0, 1.0) * (np.pi / 2)
    n = np.repeat(np.stack([np.sin(ang), np.zeros(W), -np.cos(ang)], axis=1)[None], H, axis=0)
    uv, _, lab = all_interior_points(inst, depth, color, None, texture_max_turn_deg=20.0, surface_normal=n,
                                     texture_turn_labels=np.array([2]))
    on_bevel = np.abs(uv[:, 0] - 29.5) < 2.0
    assert int(np.sum(on_bevel & (lab == 1))) > 10 and int(np.sum(on_bevel & (lab == 2))) == 0


def _step_and_ramp(H: int = 48, W: int = 64) -> np.ndarray:
    """Grey image (H, W) float: a step of 80 grey levels at x = 16 (softened like a rendered edge,
    sigma 0.5 px) and a linear ramp of 80 levels from x = 36 to x = 48 (a soft 'baked shading' edge)."""
    import cv2

    x = np.arange(W, dtype=np.float64)
    row = 60.0 + 80.0 * (x >= 16) + 80.0 * np.clip((x - 36.0) / 12.0, 0.0, 1.0)
    img = np.repeat(row[None], H, axis=0).astype(np.float32)
    return cv2.GaussianBlur(img, (0, 0), 0.5)


def test_sharpness_ratio_of_a_step_and_of_a_wide_ramp():
    from ycbvss.refine.interior_edges import MIN_SHARPNESS, sharpness_ratio

    g = _step_and_ramp()
    r = sharpness_ratio(g, np.array([24, 24]), np.array([15, 42]))
    assert 1.9 < r[0] < 2.6            # a step: 2.0 here (2.28 from the two blurs alone; Sobel smooths too)
    assert r[1] < 1.2                  # a 12 px ramp: the blur hardly changes its slope
    assert r[1] < MIN_SHARPNESS <= r[0]


def test_interior_points_drop_soft_texture_edges_only():
    """With ``texture_min_sharpness`` the template's Canny edges on the soft ramp go, the step's stay."""
    from ycbvss.refine.edge import all_interior_points

    g = np.clip(_step_and_ramp(), 0, 255).astype(np.uint8)
    H, W = g.shape
    inst = np.zeros((H, W), np.int32)
    inst[4:H - 4, 4:W - 4] = 1
    depth = np.where(inst > 0, 800.0, 0.0).astype(np.float32)
    color = np.repeat(g[..., None], 3, axis=2)
    # Canny's thresholds lowered so that the ramp's gentle slope (6.7 levels / px) yields candidates
    uv_all, _, _ = all_interior_points(inst, depth, color, None, canny_lo=5.0, canny_hi=10.0)
    uv_sharp, _, _ = all_interior_points(inst, depth, color, None, canny_lo=5.0, canny_hi=10.0, texture_min_sharpness=1.8)
    near_step = lambda uv: int(np.sum(np.abs(uv[:, 0] - 15.5) < 2.0))
    on_ramp = lambda uv: int(np.sum((uv[:, 0] > 34.0) & (uv[:, 0] < 50.0)))
    assert near_step(uv_all) > 20 and on_ramp(uv_all) > 20
    assert near_step(uv_sharp) == near_step(uv_all) and on_ramp(uv_sharp) == 0


@pytest.mark.parametrize("arc_deg, groups, gated", [(60.0, "wide", True), (20.0, "wide", False),
                                                     (20.0, "medium", True), (4.0, "medium", False),
                                                     (4.0, "narrow", True)])
def test_interior_turn_gate_at_the_finest_level_of_its_baseline_groups_only(monkeypatch, arc_deg, groups, gated):
    """``interior_turn_finest_deg``: f_edge's candidates get the normal-turn gate at the finest
    blur level of a keyframe bundle whose baseline group is listed, never at a coarser level
    (the spy records the gate per level's blur; fast-rendered procedural scene: control flow only)."""
    import ycbvss.refine.bundle as B
    from ycbvss.procedural.render import render_frame_fast
    from ycbvss.procedural.scene import make_scene

    ps = make_scene(seed=3, n_frames=3, width=320, height=240, arc_deg=arc_deg)
    imgs = {f.im_id: render_frame_fast(ps, f, noise_sigma=1.0)[0] for f in ps.frames}
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in ps.frames for i in f.instances}
    seen: list[tuple[float, float]] = []
    real = B.view_edge_candidates

    def spy(vr, **kw):
        seen.append((kw.get("blur_sigma_px") or 0.0, kw.get("interior_max_turn_deg", 0.0)))
        return real(vr, **kw)

    monkeypatch.setattr(B, "view_edge_candidates", spy)
    opt = B.RefineOptions(interior_turn_finest_deg=20.0, interior_turn_groups=groups, max_iters=1,
                          coarse_iters=1, extra_iters=0, turn_check=False, bias_removal_groups="")
    res = B.refine_scene(ps.scene, ps.models, gt, opt, images=imgs)
    finest = min(s for s, _ in seen)
    assert {g for s, g in seen if s > finest} == {0.0}
    assert {g for s, g in seen if s == finest} == ({20.0} if gated else {0.0})
    assert res.stats["interior_turn_finest_deg"] == (20.0 if gated else 0.0)


def test_interior_turn_groups_rejects_an_unknown_group():
    """A misspelt ``interior_turn_groups`` is an error naming the option, not a silently unused gate."""
    import ycbvss.refine.bundle as B
    from ycbvss.errors import YcbvssError
    from ycbvss.procedural.scene import make_scene

    ps = make_scene(seed=3, n_frames=2, width=160, height=120, arc_deg=20)
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in ps.frames for i in f.instances}
    with pytest.raises(YcbvssError, match="interior_turn_groups"):
        B.refine_scene(ps.scene, ps.models, gt, B.RefineOptions(interior_turn_groups="wdie"))


def test_interior_turn_gate_on_textureless_objects_only(monkeypatch):
    """``interior_turn_objects="textureless"``: at the gated (finest) level f_edge's candidates get
    exactly the labels of the view's textureless objects (assets flags of the procedural models);
    a misspelt value is an error naming the option."""
    import ycbvss.refine.bundle as B
    from ycbvss.errors import YcbvssError
    from ycbvss.procedural.render import render_frame_fast
    from ycbvss.procedural.scene import make_scene

    ps = make_scene(seed=3, n_frames=3, width=320, height=240, arc_deg=60.0)
    imgs = {f.im_id: render_frame_fast(ps, f, noise_sigma=1.0)[0] for f in ps.frames}
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in ps.frames for i in f.instances}
    seen: list = []
    real = B.view_edge_candidates

    def spy(vr, **kw):
        if kw.get("interior_max_turn_deg", 0.0) > 0:
            want = sorted(k + 1 for k, j in enumerate(vr.obj_index) if ps.models[sorted(ps.models)[j]].textureless)
            seen.append((sorted(kw["interior_turn_labels"].tolist()), want))
        return real(vr, **kw)

    monkeypatch.setattr(B, "view_edge_candidates", spy)
    opt = B.RefineOptions(interior_turn_finest_deg=20.0, interior_turn_groups="wide", interior_turn_objects="textureless",
                          max_iters=1, coarse_iters=1, extra_iters=0, turn_check=False, bias_removal_groups="")
    B.refine_scene(ps.scene, ps.models, gt, opt, images=imgs)
    assert seen and all(got == want for got, want in seen) and any(want for _, want in seen)
    with pytest.raises(YcbvssError, match="interior_turn_objects"):
        B.refine_scene(ps.scene, ps.models, gt, B.RefineOptions(interior_turn_objects="plain"))
