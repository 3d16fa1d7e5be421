"""Bundle pose refinement on procedural scenes rendered by the fast renderer (exact GT).

Budget: ~45 s on 2 cores (one 4-view 320x240 scene refined from a ~5 px init, one single-view
run, one bad-input run)."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from ycbvss.refine import RefineOptions, RefineResult, refine_scene
from ycbvss.eval.metrics import pose_errors_4x4
from ycbvss.refine.deviation import deviate_scene
from ycbvss.scene import Scene


@pytest.fixture(scope="module")
def scene4():
    from ycbvss.procedural.render import render_frame_fast
    from ycbvss.procedural.scene import make_scene

    ps = make_scene(seed=1, n_frames=4, width=320, height=240, arc_deg=30)
    imgs = {f.im_id: render_frame_fast(ps, f, noise_sigma=1.0)[0] for f in ps.frames}
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in ps.frames for i in f.instances}
    pts = {o: np.asarray(m.mesh.vertices)[:: max(1, len(m.mesh.vertices) // 400)] for o, m in ps.models.items()}
    return ps, imgs, gt, pts


def _mean_err(poses, gt, pts, K, objs=None):
    e = [pose_errors_4x4(poses[k], gt[k], K, pts[k[1]]) for k in gt if objs is None or k[1] in objs]
    return {m: float(np.mean([x[m] for x in e])) for m in e[0]}


def test_subpixel_recovery_from_5px_init_textured_and_textureless(scene4):
    ps, imgs, gt, pts = scene4
    K = ps.frames[0].camera.K
    init = deviate_scene(ps.T_m2w, {f.im_id: f.T_w2c for f in ps.frames}, np.random.default_rng(0),
                         t_sigma_mm=(4.0, 4.0, 25.0), r_sigma_deg=2.5)
    e0 = _mean_err(init, gt, pts, K)
    assert e0["prj_px"] > 3.0 and e0["add_mm"] > 12.0          # the init really is off by pixels / cm
    res = refine_scene(ps.scene, ps.models, init, RefineOptions(), images=imgs)
    assert isinstance(res, RefineResult)
    assert set(res.poses) == set(gt)
    # a 30 deg arc: the medium sigma group, so the table's rotation term on by default, and with it the
    # point-motion ridge at the finest level (RefineOptions.table_flow "medium", object_ridge "by_baseline")
    assert res.stats["baseline_group"] == "medium" and res.stats["table_flow"] is True
    assert res.stats["object_ridge"] == "finest"
    # ... and the appearance biases removed (RefineOptions.bias_removal_groups: lit templates, lit
    # contour prediction, f_t's residual flow, the finest level's interior turn gate)
    assert res.stats["bias_removal"] is True
    assert res.stats["template_shading"] is True and res.stats["edge_appearance"] is True
    assert res.stats["interior_turn_finest_deg"] == 20.0
    textured = [o for o, m in ps.models.items() if not m.textureless]
    plain = [o for o, m in ps.models.items() if m.textureless]
    et, ep, ea = (_mean_err(res.poses, gt, pts, K, textured), _mean_err(res.poses, gt, pts, K, plain),
                  _mean_err(res.poses, gt, pts, K))
    assert et["prj_px"] < 0.5, et
    assert ep["prj_px"] < 0.5, ep
    assert ea["add_mm"] < e0["add_mm"] / 10, (e0, ea)
    assert ea["tz_mm"] < 1.5, ea
    # every object, the textureless mug included (measured at 320x240, 4 views: PRJ <= 0.27 px,
    # R <= 0.41 deg, tz <= 0.97 mm)
    for o in ps.models:
        eo = _mean_err(res.poses, gt, pts, K, [o])
        assert eo["prj_px"] < 0.5 and eo["r_deg"] < 0.8 and eo["tz_mm"] < 2.0, (ps.models[o].name, eo)
    # the accepted steps never raise the cost
    for rec in res.log:
        if rec["accepted"]:
            assert rec["cost"] <= rec["cost_before"] + 1e-9
    # uncertainty: finite, positive, plausible (mm / deg)
    for oid, s in res.sigma["objects"].items():
        assert all(np.isfinite(s["sigma_t_mm"])) and 0 < max(s["sigma_t_mm"]) < 20.0, (oid, s)
        assert 0 < s["sigma_r_deg"] < 10.0
    assert set(res.sigma["cameras"]) == {f.im_id for f in ps.frames[1:]}
    # world = first camera
    assert np.allclose(res.T_w2c[ps.frames[0].im_id], np.eye(4))


def test_single_view_refines_objects(scene4):
    """One image: no temporal term, no free camera. Depth is only observable through the apparent
    size, so single-view refinement is fragile (measured: 3 of 5 objects improve clearly, the small
    partly occluded can and the mug drift in depth); we check that it runs and mostly improves."""
    ps, imgs, gt, pts = scene4
    f = ps.frames[0]
    rng = np.random.default_rng(3)
    init = {}
    for i in f.instances:
        T = i.T_m2c.copy()
        T[:3, 3] += rng.normal(scale=[2.0, 2.0, 0.0])     # ~1-4 px image-plane shift
        init[(f.im_id, i.obj_id)] = T
    res = refine_scene(Scene(1, [f]), ps.models, init, RefineOptions(max_iters=3), images={f.im_id: imgs[f.im_id]})
    K = f.camera.K
    p0 = np.array([pose_errors_4x4(init[k], gt[k], K, pts[k[1]])["prj_px"] for k in sorted(init)])
    p1 = np.array([pose_errors_4x4(res.poses[k], gt[k], K, pts[k[1]])["prj_px"] for k in sorted(init)])
    assert np.all(np.isfinite(p1))
    assert int((p1 < 0.7 * p0).sum()) >= 3, (p0, p1)
    assert np.median(p1) < 0.8 * np.median(p0), (p0, p1)
    assert res.sigma["cameras"] == {}


@pytest.mark.parametrize("free_gauge", [False, True])
def test_bad_inputs_never_nan(scene4, free_gauge):
    _bad_inputs_never_nan(scene4, free_gauge=free_gauge)


def test_bad_inputs_never_nan_lit_templates(scene4, monkeypatch):
    """The same bad inputs with the templates lit by the fitted lighting (f_point and the
    contour's appearance prediction; a uniform image gives a flat fit, not a NaN)."""
    import ycbvss.refine.bundle as bundle

    calls = []
    lit = bundle.lit_template
    monkeypatch.setattr(bundle, "lit_template", lambda *a, **k: calls.append(1) or lit(*a, **k))
    # f_edge along edges too: across edges only, these fast-rendered views are lit 3 times, not 6
    # (fewer outer iterations); the default's bad inputs are covered by test_bad_inputs_never_nan
    _bad_inputs_never_nan(scene4, template_shading=True, edge_appearance=True, edge_across_only=False)
    assert len(calls) >= 6        # the 3 views' templates were lit, iteration after iteration


def _bad_inputs_never_nan(scene4, **opts):
    ps, imgs, gt, pts = scene4
    frames = ps.frames[:3]
    ims = {f.im_id: imgs[f.im_id] for f in frames}
    ims[frames[2].im_id] = np.full_like(ims[frames[2].im_id], 90)      # uniform image: empty edge field
    init = {k: v.copy() for k, v in gt.items() if k[0] in ims}
    del init[(frames[1].im_id, 3)]                                       # missing pair
    del init[(frames[0].im_id, 4)]
    init[(frames[0].im_id, 1)] = np.full((4, 4), np.nan)                 # NaN init: dropped
    T = init[(frames[1].im_id, 2)].copy()
    T[2, 3] = -500.0
    init[(frames[1].im_id, 2)] = T                                       # behind the camera: dropped
    for f in frames:                                                     # object 5: off the image in every view
        T = init[(f.im_id, 5)].copy()
        T[0, 3] += 3000.0
        init[(f.im_id, 5)] = T
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        res = refine_scene(Scene(1, frames), ps.models, init, RefineOptions(max_iters=2, coarse_iters=1, **opts),
                           images=ims)
    assert sum("invalid init pose" in str(x.message) for x in w) == 2
    assert len(res.poses) == 3 * 5                                         # every (view, object) gets a pose
    assert all(np.all(np.isfinite(T)) for T in res.poses.values())
    assert isinstance(res.converged, bool)
    assert not any(k[1] == 5 for k in res.visible)                        # never visible: no image terms
    f0 = frames[0].im_id     # its pose in the first camera stays the initialisation (also with the cameras free)
    assert np.allclose(res.poses[(f0, 5)], res.init_poses[(f0, 5)], atol=1e-3)
    # objects stay close to GT in the good views despite the bad ones (robust init + refinement)
    e = _mean_err(res.poses, {k: gt[k] for k in res.poses if k[0] != frames[2].im_id and k[1] != 5}, pts,
                  frames[0].camera.K)
    assert e["prj_px"] < 2.0, e


def test_object_without_any_init_is_reported(scene4):
    ps, imgs, gt, pts = scene4
    f = ps.frames[0]
    init = {k: v for k, v in gt.items() if k[0] == f.im_id and k[1] != 2}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = refine_scene(Scene(1, [f]), ps.models, init, RefineOptions(max_iters=1, coarse_iters=0,
                                                                          edge_sigmas_px=(1.0,)),
                           images={f.im_id: imgs[f.im_id]})
    assert res.missing_objects == [2]
    assert (f.im_id, 2) not in res.poses and len(res.poses) == 4


def test_keyframes_then_camera_only_refinement():
    from ycbvss.procedural.render import render_frame_fast
    from ycbvss.procedural.scene import make_scene

    ps = make_scene(seed=1, n_frames=7, width=320, height=240, arc_deg=36)
    imgs = {f.im_id: render_frame_fast(ps, f, noise_sigma=1.0)[0] for f in ps.frames}
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in ps.frames for i in f.instances}
    pts = {o: np.asarray(m.mesh.vertices)[:: max(1, len(m.mesh.vertices) // 300)] for o, m in ps.models.items()}
    init = deviate_scene(ps.T_m2w, {f.im_id: f.T_w2c for f in ps.frames}, np.random.default_rng(0))
    # frames 1 and 4 have no init at all: their cameras come from SE(3) interpolation + refinement
    init = {k: v for k, v in init.items() if k[0] not in (1, 4)}
    res = refine_scene(ps.scene, ps.models, init, RefineOptions(keyframe_step=3, max_iters=4), images=imgs)
    K = ps.frames[0].camera.K
    nonkey = {1, 2, 4, 5}
    e = _mean_err(res.poses, {k: v for k, v in gt.items() if k[0] in nonkey}, pts, K)
    ek = _mean_err(res.poses, {k: v for k, v in gt.items() if k[0] not in nonkey}, pts, K)
    assert ek["prj_px"] < 1.0 and e["prj_px"] < 1.0, (ek, e)
    assert set(res.sigma["cameras"]) == {1, 2, 3, 4, 5, 6}
    assert any(rec["stage"].startswith("frames") for rec in res.log)


def test_viewing_baseline_decides_the_blur_schedule(scene4):
    """The angle under which the scene centre sees the keyframe cameras: the procedural 30 deg arc
    is wide (coarse-to-fine from 8 px), the same view repeated is narrow (from 4 px)."""
    from ycbvss.refine.bundle import viewing_baseline_deg

    ps, imgs, gt, pts = scene4
    Tc = np.stack([f.T_w2c for f in ps.frames])
    Tm = np.stack(list(ps.T_m2w.values()))
    wide = viewing_baseline_deg(Tc, Tm)
    assert 25.0 < wide < 35.0, wide
    assert viewing_baseline_deg(np.stack([Tc[0], Tc[0]]), Tm) < 1e-3
    f = ps.frames[0]
    init = {(im, o): T for (im, o), T in gt.items()}
    two = Scene(1, [f, f.__class__(**{**f.__dict__, "im_id": f.im_id + 100})])
    res = refine_scene(two, ps.models, {**init, **{(f.im_id + 100, o): T for (im, o), T in init.items()
                                                   if im == f.im_id}},
                       RefineOptions(max_iters=1, coarse_iters=1, extra_iters=0, compute_uncertainty=False),
                       images={f.im_id: imgs[f.im_id], f.im_id + 100: imgs[f.im_id]})
    assert res.stats["baseline_deg"] < 1.0
    # a narrow bundle: its own sigma group, and (default object_ridge="narrow") the point-motion ridge at every level
    assert res.stats["baseline_group"] == "narrow" and res.stats["object_ridge"] == "every"
    # ... and f_point's templates lit by each view's fitted lighting (template_shading="narrow")
    assert res.stats["template_shading"] is True and res.stats["edge_appearance"] is False
    assert sorted({r["stage"].split(" outer")[0] for r in res.log if r["stage"].startswith("keyframes")}) == \
        ["keyframes sigma=1", "keyframes sigma=2"]       # 320 px wide: (4, 2, 1) px levels scale to (2, 1)


def test_lit_template_options_are_checked(scene4):
    from ycbvss.errors import YcbvssError

    ps, imgs, gt, pts = scene4
    for name in ("template_shading", "edge_appearance"):
        with pytest.raises(YcbvssError, match=f"RefineOptions.{name} must be True, False, 'narrow' or 'medium'"):
            refine_scene(ps.scene, ps.models, gt, RefineOptions(**{name: "wide"}), images=imgs)


def test_rim_depth_option_refines_like_the_default(scene4):
    """``edge_rim_depth`` (contour samples lifted at the rim from the back-face pass; by default on
    wide scenes only, so off for this one) runs the whole bundle and reaches the accuracy without it
    (a unit test, fast-rendered images: not evidence of accuracy on real data; the suite's long clips
    measure it, see bench/results/ycbv21/README.md). Measured at 320x240, 4 views, from a 3.8 px /
    13.5 mm init, 4 finest iterations: without / with PRJ 0.150 / 0.155 px, tz 1.08 / 0.99 mm."""
    ps, imgs, gt, pts = scene4
    K = ps.frames[0].camera.K
    init = deviate_scene(ps.T_m2w, {f.im_id: f.T_w2c for f in ps.frames}, np.random.default_rng(3),
                         t_sigma_mm=(3.0, 3.0, 15.0), r_sigma_deg=2.0)
    opt = dict(max_iters=4, coarse_iters=2, extra_iters=0, compute_uncertainty=False)
    errs = {}
    for rim in (False, True):
        res = refine_scene(ps.scene, ps.models, init, RefineOptions(edge_rim_depth=rim, **opt), images=imgs)
        errs[rim] = _mean_err(res.poses, gt, pts, K)
    assert errs[True]["prj_px"] < 0.3 and errs[True]["tz_mm"] < 1.5, errs
    assert abs(errs[True]["tz_mm"] - errs[False]["tz_mm"]) < 0.5, errs


def test_held_objects_keep_their_pose_and_the_cameras_are_refined(scene4):
    """``fix_objects`` (a diagnostic, bench/suite_camera_drift.py): the objects stay where the init
    puts them in the world and each camera alone is refined -- here frame 2's camera starts
    0.5 deg / 3 mm off (the same rigid error on every object of that frame) and comes back."""
    from ycbvss.errors import YcbvssError
    from ycbvss.geometry.se3 import exp_se3

    ps, imgs, gt, pts = scene4
    ims = sorted({k[0] for k in gt})
    D = exp_se3(np.array([3.0, -2.0, 0.0, 0.0, np.deg2rad(0.5), 0.0]))
    init = {k: (D @ T if k[0] == ims[2] else T.copy()) for k, T in gt.items()}
    res = refine_scene(ps.scene, ps.models, init, RefineOptions(fix_objects=True, max_iters=3, compute_uncertainty=False),
                       images=imgs)
    K = ps.frames[0].camera.K
    before = _mean_err(init, {k: v for k, v in gt.items() if k[0] == ims[2]}, pts, K)
    after = _mean_err(res.poses, {k: v for k, v in gt.items() if k[0] == ims[2]}, pts, K)
    assert before["prj_px"] > 3.0 and after["prj_px"] < 0.3, (before, after)   # measured 6.7 -> 0.05 px
    # the objects did not move relative to each other (the first camera is refined too: the gauge
    # is re-registered to the bundle, RefineOptions.register_gauge)
    objs = sorted(res.T_m2w)
    a = objs[0]
    for b in objs[1:]:
        rel = np.linalg.inv(res.T_m2w[a]) @ res.T_m2w[b]
        rel_gt = np.linalg.inv(gt[(ims[0], a)]) @ gt[(ims[0], b)]
        assert np.allclose(rel, rel_gt, atol=1e-6), (a, b)
    with pytest.raises(YcbvssError, match="fix_cameras and fix_objects together"):
        refine_scene(ps.scene, ps.models, gt, RefineOptions(fix_cameras=True, fix_objects=True), images=imgs)


def test_slide_restart_only_when_an_object_left_its_basin(scene4):
    """``slide_restart``: nothing slid on this scene, so the result is the single pass's; the rule
    that picks the objects is the status's "projection moved" one."""
    from types import SimpleNamespace

    from ycbvss.refine.bundle import _slid_objects
    from ycbvss.refine.confidence import shift_limit_px

    ps, imgs, gt, pts = scene4
    opt = dict(max_iters=2, compute_uncertainty=False)
    a = refine_scene(ps.scene, ps.models, gt, RefineOptions(slide_restart=False, **opt), images=imgs)
    b = refine_scene(ps.scene, ps.models, gt, RefineOptions(slide_restart=True, **opt), images=imgs)
    assert "slide_restart" not in b.stats and b.stats["edge_sigmas_px"] == a.stats["edge_sigmas_px"]
    assert all(np.array_equal(a.poses[k], b.poses[k]) for k in a.poses)
    lim = shift_limit_px(2.0, 640)
    fake = SimpleNamespace(quality={1: {"shift_px": lim + 1, "init_scatter_px": 2.0},
                                    2: {"shift_px": lim - 1, "init_scatter_px": 2.0}, 3: {}}, stats={})
    assert _slid_objects(fake, 640) == [1]
    fake.stats["ridge_fallback"] = [[3]]          # put back by the finest level's ridge fallback: a runaway
    assert _slid_objects(fake, 640) == [1, 3]
    from ycbvss.errors import YcbvssError
    with pytest.raises(YcbvssError, match="RefineOptions.slide_restart must be True, False or 'coarse'"):
        refine_scene(ps.scene, ps.models, gt, RefineOptions(slide_restart="narrow"), images=imgs)
