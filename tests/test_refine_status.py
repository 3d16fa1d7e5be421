"""Status and confidence of refined poses, and no silent failures (unit tests; the images come from
the fast renderer, so they are no evidence of accuracy -- tests/test_refine_suite.py is).

Budget: ~40 s on 2 cores."""
from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.sparse as sp

from ycbvss.refine import RefineOptions, refine_scene
from ycbvss.refine.confidence import classify, contour_offset_px, shift_limit_px, worst_views_px
from ycbvss.refine.edge import gradient_magnitude
from ycbvss.refine.io import estimates_of
from ycbvss.refine.solver import damped_solve


@pytest.fixture(scope="module")
def scene3():
    from ycbvss.procedural.render import render_frame_fast
    from ycbvss.procedural.scene import make_scene

    ps = make_scene(seed=2, n_frames=3, width=320, height=240, arc_deg=20)
    imgs = {f.im_id: render_frame_fast(ps, f, noise_sigma=1.0)[0] for f in ps.frames}
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in ps.frames for i in f.instances}
    return ps, imgs, gt


def test_damped_solve_returns_none_for_a_singular_or_nonfinite_system_and_raises_on_bugs():
    H = np.zeros((6, 6))
    H[0, 0] = np.nan
    assert damped_solve(H, np.ones(6), 1e-3) is None
    assert damped_solve(np.eye(6), np.full(6, np.inf), 1e-3) is None
    d = damped_solve(sp.csr_matrix(np.eye(12) * 2.0), np.ones(12), 0.0)
    assert d is not None and np.allclose(d, -0.5, atol=1e-6)
    with pytest.raises(Exception) as ei:      # a programming error is not swallowed into a zero step
        damped_solve(np.eye(6), np.ones(7), 1e-3)
    assert not isinstance(ei.value, np.linalg.LinAlgError)


def test_classify_rules():
    ok = classify(0.3, 0.5, 0.1, observed=True)
    assert ok.status == "converged" and ok.confidence > 0.8
    assert classify(1.6, 0.5, 0.0, True).status == "uncertain"
    bad = classify(2.9, 0.5, 0.0, True)
    assert bad.status == "failed" and bad.confidence <= 0.1
    assert classify(0.3, 5.0, 0.0, True).status == "uncertain"         # large calibrated sigma
    assert classify(0.3, 0.5, 0.6, True).status == "uncertain"         # moved more than its sigma
    assert classify(0.3, 1.0, 0.6, True).status == "converged"         # ... or not
    assert classify(0.3, 0.5, 0.0, False).status == "uncertain"        # no image terms
    nan = classify(0.3, 0.5, 0.0, True, numerical_failure=True)
    assert nan.status == "failed" and nan.confidence == 0.0
    # px thresholds are for 640-px images: at 320 px, 0.6 px is the misalignment 1.2 px is at 640
    # (the demo's 85 %-occluded plain mug, 4.6 deg off, measured 0.60 px at 320 px)
    assert classify(0.6, 0.5, 0.0, True).status == "converged"
    assert classify(0.6, 0.5, 0.0, True, width_px=320).status == "uncertain"
    assert classify(1.4, 0.5, 0.0, True, width_px=320).status == "failed"
    assert classify(1.6, 0.5, 0.0, True, width_px=1280).status == "converged"
    # an object that left its initial basin: the suite's foam brick flipped 75 deg, silhouette 0.07 px off
    flip = classify(0.07, 0.5, 0.0, True, turned_deg=75.0)
    assert flip.status == "uncertain" and "turned 75 deg" in flip.reason and flip.confidence < 0.5
    assert classify(0.07, 0.5, 0.0, True, turned_deg=5.0).status == "converged"
    # ... or slid sideways: the suite's foam brick ended 35 mm off (23 px) with its silhouette 0.37 px off
    lim = shift_limit_px(4.0)
    assert lim == 15.0 and shift_limit_px(4.0, width_px=1280) == 30.0 and shift_limit_px(14.0) == 42.0
    slid = classify(0.37, 0.5, 0.0, True, shifted_px=23.5, shift_limit_px=lim)
    assert slid.status == "uncertain" and "moved 24 px" in slid.reason and slid.confidence < 0.5
    assert classify(0.37, 0.5, 0.0, True, shifted_px=4.0, shift_limit_px=lim).status == "converged"
    # no contour of its own: its view's offset does not verify it (the suite's large marker ended
    # 20 deg tilted, ADD 18 mm, in every view of medium-5 and took its view's 0.3 px), but can fail it
    hidden = classify(0.3, 0.5, 0.0, True, own_contour=False)
    assert hidden.status == "uncertain" and "own contour not visible" in hidden.reason and hidden.confidence < 0.5
    assert classify(2.9, 0.5, 0.0, True, own_contour=False).status == "failed"
    # fits the median view but not the views that show it most: the suite's large clamp, hidden
    # behind a can in the first frames of medium-1 (seed 5), ended 12 mm too close with a 0.23 px
    # median offset, 1.8 and 2.7 px in two of its 30 views (<= 0.35 px in every view at the GT)
    worst = classify(0.23, 0.5, 0.0, True, worst_contour_px=1.82)
    assert worst.status == "uncertain" and "in some of its views" in worst.reason and worst.confidence < 0.5
    assert classify(0.23, 0.5, 0.0, True, worst_contour_px=0.35).status == "converged"
    assert classify(0.23, 0.5, 0.0, True, worst_contour_px=0.9, width_px=320).status == "uncertain"


def test_worst_views_px_needs_two_views_to_agree():
    clamp = [0.56, 0.46, 0.7, 0.56, 0.59, 0.53, 0.49, 0.36, 0.44, 0.32, 0.36, 0.27, 0.21, 0.23, 0.18,
             0.12, 0.1, 0.11, 0.1, 0.11, 0.12, 0.07, 0.1, 0.12, 0.12, 0.16, 1.82, 2.72, 0.11, 0.22]
    assert worst_views_px(clamp) == pytest.approx(1.82)           # k = 2 of 30 views
    assert worst_views_px([0.2, 0.3, 3.0, float("nan")]) == pytest.approx(0.3)   # one view alone does not decide
    assert np.isnan(worst_views_px([2.0])) and np.isnan(worst_views_px([]))
    long = [0.2] * 190 + [3.0] * 9 + [1.5]                         # 200 views: k = 10
    assert worst_views_px(long) == pytest.approx(1.5)
    # views showing less than half of its longest visible contour do not count
    assert worst_views_px([0.2, 0.3, 2.5, 2.8], [300, 280, 100, 120]) == pytest.approx(0.2)
    assert worst_views_px([0.2, 0.3, 2.5, 2.8], [300, 280, 200, 220]) == pytest.approx(2.5)


def test_contour_offset_measures_a_shifted_silhouette(scene3):
    """Median over the views (as the refiner reports it): a fraction of a pixel at the exact
    poses, clearly more when every object is shifted laterally by 4 mm (about 2 px here)."""
    from ycbvss.refine.templates import composite, ensure_meshes, get_renderer, render_view

    ps, imgs, _ = scene3
    r = get_renderer()
    ensure_meshes(r, ps.models)

    def offsets(f, dt):
        oids = [i.obj_id for i in f.instances]
        P = {j: i.T_m2c.copy() for j, i in enumerate(f.instances)}
        for T in P.values():
            T[:3, 3] += dt
        vr = render_view(r, ps.models, oids, f.camera.K, f.camera.width, f.camera.height, P)
        mag = gradient_magnitude(imgs[f.im_id], 1.0)
        mt = gradient_magnitude(composite(vr, imgs[f.im_id]), 1.0)
        return [contour_offset_px(mag, mt, vr.instance, vr.depth_mm, vr.label_of(j)) for j in range(len(oids))]

    at_gt = np.nanmedian([offsets(f, np.zeros(3)) for f in ps.frames], axis=0)
    shifted = np.nanmedian([offsets(f, np.array([4.0, 0.0, 0.0])) for f in ps.frames], axis=0)
    assert np.max(at_gt) < 0.8, at_gt
    assert np.min(shifted) > 1.0, shifted
    assert np.all(shifted > at_gt + 0.5), (at_gt, shifted)


def test_status_confidence_and_score(scene3):
    ps, imgs, gt = scene3
    res = refine_scene(ps.scene, ps.models, gt, RefineOptions(), images=imgs)
    assert set(res.status) == set(res.poses) == set(res.confidence)
    assert all(s in ("converged", "uncertain", "failed") for s in res.status.values())
    assert all(0.0 <= c <= 1.0 for c in res.confidence.values())
    # 6 of 15 poses are 'converged' (translation errors 0.2-0.8 mm); the others carry sigma_ADD
    # above 2 mm (errors up to 2.5 mm) or a contour 0.6 px off the image edges
    conv = [k for k, s in res.status.items() if s == "converged"]
    assert len(conv) >= len(res.status) // 3, res.reasons
    t_err_mm = {k: float(np.linalg.norm(res.poses[k][:3, 3] - gt[k][:3, 3])) for k in conv}
    assert max(t_err_mm.values()) < 1.5, t_err_mm
    ests = estimates_of(1, res)
    assert {(e.im_id, e.obj_id): e.score for e in ests} == {k: pytest.approx(v) for k, v in res.confidence.items()}
    # reported sigmas: a converged pose keeps its covariance-plus-floor sigma; any other pose reports at
    # least its ADD sigma's per-axis share on every translation axis
    from ycbvss.refine.confidence import sigma_floor, total_sigma
    fl = np.array(sigma_floor(res.stats["baseline_group"]))
    unsettled = 0
    for k, sp in res.sigma["poses"].items():
        sa = sp["sigma_add_mm"]
        assert np.isfinite(sa) and sa > 0.0, (k, sp)
        if res.status[k] == "converged":
            np.testing.assert_allclose(sp["sigma_t_mm"], total_sigma(sp["sigma_stat_t_mm"], fl[:3]), rtol=1e-12)
        else:
            unsettled += 1
            assert min(sp["sigma_t_mm"]) >= sa / np.sqrt(3.0) - 1e-12, (k, sp)
    assert unsettled >= 1, res.status


def test_a_pose_that_is_not_converged_reports_its_add_sigma_on_every_translation_axis():
    """unsettled_sigma_t_mm: each axis at least sigma_add / sqrt(3) (the ADD sigma spread evenly);
    an axis already wider keeps its sigma. The suite report applies the same rule to its rows."""
    from ycbvss.pipeline.suite_report import row_sigmas
    from ycbvss.refine.confidence import sigma_floor, sigma_scale, total_sigma, unsettled_sigma_t_mm

    np.testing.assert_allclose(unsettled_sigma_t_mm([0.2, 0.3, 4.0], 3.0 * np.sqrt(3.0)), [3.0, 3.0, 4.0])
    np.testing.assert_allclose(unsettled_sigma_t_mm([0.2, 0.3, 4.0], 0.0), [0.2, 0.3, 4.0])
    row = {"kind": "short", "status": "uncertain", "sigma_tx_mm": 0.1, "sigma_ty_mm": 0.1, "sigma_tz_mm": 2.0,
           "sigma_r_deg": 0.2, "sigma_add_mm": 2.95}
    f, fl = np.array(sigma_scale("narrow")), np.array(sigma_floor("narrow"))
    plain = total_sigma(f * np.array([0.1, 0.1, 2.0, 0.2]), fl)
    widened = row_sigmas(row)
    np.testing.assert_allclose(widened[:2], 2.95 / np.sqrt(3.0))     # a 2.8 mm sideways error is now within 2 sigma
    assert widened[2] == pytest.approx(max(plain[2], 2.95 / np.sqrt(3.0)))
    assert widened[3] == pytest.approx(plain[3])                      # rotation unchanged
    np.testing.assert_allclose(row_sigmas({**row, "status": "converged"}), plain)
    np.testing.assert_allclose(row_sigmas({k: v for k, v in row.items() if k != "sigma_add_mm"}), plain)


def test_a_nan_pose_is_failed_and_named_never_silently_replaced(scene3, monkeypatch):
    import ycbvss.refine.bundle as bundle

    ps, imgs, gt = scene3
    orig = bundle._Stage.run

    def run_then_break(self, sigmas):          # a NaN appears in object index 1's world pose
        terms = orig(self, sigmas)
        if self.name == "keyframes":
            self.pb.T_m[1][:3, 3] = np.nan
        return terms

    monkeypatch.setattr(bundle._Stage, "run", run_then_break)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        res = refine_scene(ps.scene, ps.models, gt, RefineOptions(max_iters=1, extra_iters=0, coarse_iters=1),
                           images=imgs)
    oid = sorted(ps.models)[1]
    bad = {k for k in res.poses if k[1] == oid}
    assert all(res.status[k] == "failed" and res.confidence[k] <= 0.1 for k in bad)
    assert all(res.status[k] != "failed" for k in res.poses if k[1] != oid)
    msgs = [str(x.message) for x in w if f"object {oid}" in str(x.message)]
    assert len(msgs) == 1 and "scene 1" in msgs[0] and "frames 0-2" in msgs[0] and "failed" in msgs[0], msgs
    assert all(np.all(np.isfinite(res.poses[k])) for k in bad)
    assert res.converged is False


def test_no_valid_init_pose_gives_an_empty_result_not_a_crash(scene3):
    ps, imgs, gt = scene3
    bad = {k: np.full((4, 4), np.nan) for k in gt}
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        res = refine_scene(ps.scene, ps.models, bad, RefineOptions(), images=imgs)
    assert res.poses == {} and res.missing_objects == sorted(ps.models)
    assert any("no valid init pose" in str(x.message) for x in w)


def test_a_non_keyframe_is_no_more_settled_than_its_keyframes():
    """Held-out long clip 3: the keyframe bundle still moved by millimetres at its iteration cap
    while the camera-only frames between its keyframes had stopped; they now inherit the larger move
    of the two keyframes around them."""
    from ycbvss.refine.bundle import _nonkey_moves

    mm, deg = np.zeros(7), np.zeros(7)
    kf, nonkey = [0, 3, 6], [1, 2, 4, 5]
    mm[kf], deg[kf] = [0.0, 2.0, 0.1], [0.0, 0.3, 0.01]
    own = {"cam_move_mm": np.full(7, 0.05), "cam_move_deg": np.full(7, 0.002)}
    _nonkey_moves(mm, deg, kf, nonkey, own)
    assert np.allclose(mm[nonkey], 2.05) and np.allclose(deg[nonkey], 0.302)
    assert np.allclose(mm[kf], [0.0, 2.0, 0.1])            # the keyframes keep their own moves
    assert classify(0.3, 0.5, mm[1], True).status == "uncertain"


def _view1_moved(scene3, dx_mm: float) -> tuple[list, list, dict]:
    """(views with images, obj_ids, the exact poses with every object of view 1 moved ``dx_mm``
    along the camera x axis) of the 3-view scene."""
    from ycbvss.refine.problem import View
    from ycbvss.refine.templates import ensure_meshes, get_renderer

    ps, imgs, gt = scene3
    ensure_meshes(get_renderer(), ps.models)
    frames = sorted(ps.frames, key=lambda f: f.im_id)
    views = [View(f.im_id, f.camera.K, f.camera.width, f.camera.height, imgs[f.im_id]) for f in frames]
    obj_ids = sorted({i.obj_id for f in frames for i in f.instances})
    poses = {k: T.copy() for k, T in gt.items()}
    for o in obj_ids:
        poses[(frames[1].im_id, o)][:3, 3] += (dx_mm, 0.0, 0.0)
    return views, obj_ids, poses


def test_a_camera_left_off_flags_every_pose_of_its_view(scene3):
    """A camera solved wrongly (here: every object of view 1 shifted 4 mm sideways, about 2 px) while
    the objects fit the other views: the per-object median over views still reads a tight contour,
    the per-view median does not, and the view's poses are no longer 'converged'. Found on the suite
    (long clip 1 from initial ADD 40 mm): frames 0 and 63 ended 5 deg off on all objects (ADD 12-32 mm),
    reported converged."""
    from ycbvss.refine import bundle as B
    from ycbvss.refine import evidence as Ev

    ps, _, _ = scene3
    views, obj_ids, poses = _view1_moved(scene3, 4.0)
    per_view = Ev._view_contour_offsets(views, ps.models, obj_ids, np.ones(len(obj_ids), bool), poses)
    view_px = np.array([np.median(list(per_view[i].values())) for i in range(len(views))])
    quality = Ev._object_quality(per_view, ps.models, obj_ids)
    assert view_px[1] > 1.0 and view_px[0] < 0.8 and view_px[2] < 0.8, view_px
    n = len(views)
    vidx = {v.im_id: i for i, v in enumerate(views)}
    sigma = {"poses": {k: {"sigma_t_mm": np.array([0.1, 0.1, 0.3]), "sigma_r_deg": 0.05} for k in poses}}
    zeros = (np.zeros(len(obj_ids)), np.zeros(len(obj_ids)))
    args = (poses, views, vidx, obj_ids, sigma, quality, zeros, (np.zeros(n), np.zeros(n)), set(poses), set(),
            np.zeros(len(obj_ids)), (np.zeros(len(obj_ids)), np.full(len(obj_ids), 4.0)))
    before, _, _ = B._statuses(*args)
    after, conf, reasons = B._statuses(*args, view_contour_px=view_px)
    bad = [k for k in poses if k[0] == views[1].im_id]
    assert any(before[k] == "converged" for k in bad), before
    assert all(after[k] != "converged" for k in bad), reasons
    assert all(after[k] == before[k] for k in poses if k not in bad)


def test_a_view_whose_objects_are_all_moved_reads_their_2d_shift(scene3):
    """The per-view camera check (:mod:`ycbvss.refine.view_shift`): fast-rendered views at the
    exact poses read 0-1 px; every object of view 1 moved 20 mm sideways (about 6-8 px at 320 px
    and 0.8-1 m) reads several pixels there only."""
    from ycbvss.refine import evidence as Ev
    from ycbvss.refine.confidence import VIEW_SHIFT_PX
    from ycbvss.refine.view_shift import view_shift_px

    ps, _, _ = scene3
    views, obj_ids, poses = _view1_moved(scene3, 20.0)
    shifts: dict = {}
    Ev._view_contour_offsets(views, ps.models, obj_ids, np.ones(len(obj_ids), bool), poses, shifts=shifts)
    per_view = [view_shift_px(shifts.get(i, {}).values()) for i in range(len(views))]
    assert per_view[0] <= 1.0 and per_view[2] <= 1.0, per_view
    assert per_view[1] > VIEW_SHIFT_PX * 320 / 640 * 2, per_view


def test_a_non_keyframe_starts_from_the_camera_the_image_supports(scene3):
    """Non-keyframe cameras start from their own init camera or the keyframes' interpolation,
    whichever puts the view's objects on the image's edges (found on the suite, long clip 1 from
    initial ADD 40 mm: non-keyframe cameras that started from their noisy init camera ended 6-7 deg
    off). Unit test on the fast renderer's images: only the choice is tested, not accuracy."""
    from ycbvss.geometry.so3 import exp_so3
    from ycbvss.refine import bundle as B
    from ycbvss.refine.problem import View
    from ycbvss.refine.templates import ensure_meshes, get_renderer

    ps, imgs, gt = scene3
    ensure_meshes(get_renderer(), ps.models)
    frames = sorted(ps.frames, key=lambda f: f.im_id)
    views = [View(f.im_id, f.camera.K, f.camera.width, f.camera.height, imgs[f.im_id]) for f in frames]
    obj_ids = sorted({i.obj_id for f in frames for i in f.instances})
    T_m = np.stack([gt[(frames[0].im_id, o)] for o in obj_ids])            # world = camera 0
    T_c = np.stack([gt[(f.im_id, obj_ids[0])] @ np.linalg.inv(T_m[0]) for f in frames])
    wrong = T_c[1].copy()
    c = np.mean([T_m[j][:3, 3] for j in range(len(obj_ids))], axis=0)     # orbit 3 deg about the scene centre
    R = exp_so3(np.radians([0.0, 3.0, 0.0]))
    D = np.eye(4)
    D[:3, :3], D[:3, 3] = R, c - R @ c
    wrong = wrong @ D
    ok = np.ones(len(obj_ids), bool)
    Tc = T_c.copy()
    Tc[1] = wrong
    assert B._choose_nonkey_cameras(views, ps.models, obj_ids, ok, Tc, T_m, {1: T_c[1]}, [1]) == 1
    assert np.allclose(Tc[1], T_c[1])
    Tc = T_c.copy()
    assert B._choose_nonkey_cameras(views, ps.models, obj_ids, ok, Tc, T_m, {1: wrong}, [0, 1, 2]) == 0
    assert np.allclose(Tc, T_c)


@pytest.mark.parametrize("gauge", ["free_gauge", "register_gauge"])
def test_free_gauge_returns_the_world_of_the_first_camera(scene3, gauge):
    """``free_gauge``: every keyframe camera is solved free, the world is moved back to the first
    camera; ``register_gauge``: the first camera alone is fitted to the rest after each solve and
    the world moved back to it. Either way the result keeps world = first camera and the same
    consistency P = T_w2c T_m2w. (A fast-rendered scene: an invariance check, not evidence of
    accuracy; the measured effect on Blender-rendered suite clips is in the README.)"""
    ps, imgs, gt = scene3
    init = {k: T.copy() for k, T in gt.items()}
    for k in init:
        init[k][:3, 3] += (3.0, -2.0, 15.0)
    res = refine_scene(ps.scene, ps.models, init, RefineOptions(**{gauge: True}), images=imgs)
    first = min(res.T_w2c)
    assert np.abs(res.T_w2c[first] - np.eye(4)).max() < 1e-9
    for (im, o), P in res.poses.items():
        assert np.abs(P - res.T_w2c[im] @ res.T_m2w[o]).max() < 1e-6
    t_err_mm = [float(np.linalg.norm(res.poses[k][:3, 3] - gt[k][:3, 3])) for k in res.poses]
    # from 15.4 mm off: median 0.65 mm free, 1.01 registered, 0.52 with the first camera fixed; max 4.4
    assert np.median(t_err_mm) < 1.5, t_err_mm


def test_reported_sigma_adds_the_systematic_floor_but_the_status_reads_the_covariance_part():
    """calibrate_sigmas: per-view pose sigma = sqrt((factor x covariance sigma)^2 + floor^2) per
    axis; the statistical part is kept for the status rule (a floor constant per clip type must not
    turn every short-clip pose uncertain); world-frame groups get the factors only."""
    from ycbvss.refine.confidence import baseline_group, calibrate_sigmas, sigma_floor, sigma_scale

    for group in ("narrow", "medium", "wide"):
        f, fl = np.array(sigma_scale(group)), np.array(sigma_floor(group))
        raw_t, raw_r = np.array([0.05, 0.2, 1.0]), 0.03
        sig = {"poses": {(0, 1): {"sigma_t_mm": raw_t.tolist(), "sigma_r_deg": raw_r}},
               "objects": {1: {"sigma_t_mm": raw_t.tolist(), "sigma_r_deg": raw_r}}}
        calibrate_sigmas(sig, group)
        p, o = sig["poses"][(0, 1)], sig["objects"][1]
        np.testing.assert_allclose(p["sigma_stat_t_mm"], f[:3] * raw_t, rtol=1e-12)
        np.testing.assert_allclose(p["sigma_t_mm"], np.hypot(f[:3] * raw_t, fl[:3]), rtol=1e-12)
        assert p["sigma_r_deg"] == pytest.approx(np.hypot(f[3] * raw_r, fl[3]), rel=1e-12)
        np.testing.assert_allclose(o["sigma_t_mm"], f[:3] * raw_t, rtol=1e-12)
        assert "sigma_stat_t_mm" not in o
    # the floor is the measured depth bias scale: it shrinks as the views spread
    assert sigma_floor("narrow")[2] > sigma_floor("medium")[2] > sigma_floor("wide")[2] > 0.0
    assert [baseline_group(True, 60.0), baseline_group(False, 19.0), baseline_group(False, 60.0)] == \
        ["narrow", "medium", "wide"]
    with pytest.raises(ValueError):
        sigma_floor("long")


def test_the_ridge_does_not_stall_an_object_turning_about_its_own_centre():
    """damped_solve's small ridge on an object block is measured by how far the step moves the
    object's points (BundleProblem.object_ridges), so a turn about the object's own centre, 1.45 m
    from the world origin, gets the full Newton step. With the ridge eps * I in the world-origin
    se(3) coordinates the same step shrank to a few per cent (found on the suite: the marker crept
    0.03-0.08 deg per outer iteration and stopped 1.2 deg off). Pure linear algebra, no images."""
    from ycbvss.refine.problem import BundleProblem, View, _hat, model_moments

    rng = np.random.default_rng(3)
    pts = rng.normal(scale=20.0, size=(400, 3))                  # model points (mm), an object ~20 mm in size
    T_m = np.eye(4)
    T_m[:3, 3] = (80.0, -40.0, 1450.0)                           # 1.45 m in front of the world origin
    X = pts + T_m[:3, 3]
    J = np.concatenate([np.hstack([np.eye(3), -_hat(x)]) for x in X])   # point displacement per (v, w)
    H = J.T @ J                                                  # the points observed in 3-D: a well-posed block
    c = X.mean(0)
    w = np.radians([0.0, 1.0, 0.0])
    d_true = np.r_[-np.cross(w, c), w]                           # 1 deg about the object's own centre
    g = -H @ d_true
    pb = BundleProblem([View(0, np.eye(3), 640, 480)], [1], np.eye(4)[None], T_m[None], obj_moments=[model_moments(pts)])
    ridges = pb.object_ridges()
    assert [b for b, _ in ridges] == [0]
    d_q = damped_solve(H, g, 1e-7, ridges)
    d_i = damped_solve(H, g, 1e-7)
    frac = lambda d: float(d[3:] @ w / (w @ w))
    assert frac(d_q) > 0.99, frac(d_q)                          # measured 0.997
    assert frac(d_i) < 0.5, frac(d_i)                           # measured 0.15: the old ridge stalls it
    # Q: the mean squared displacement of the points, exactly, for any step
    for d in (d_true, rng.normal(size=6)):
        disp = (J @ d).reshape(-1, 3)
        assert d @ ridges[0][1] @ d == pytest.approx(np.mean(np.sum(disp ** 2, 1)), rel=1e-9)


def test_the_point_motion_ridge_by_viewing_baseline():
    """RefineOptions.object_ridge: at which blur levels a keyframe bundle uses the point-motion
    ridge. Default "by_baseline": every level on narrow bundles (short clips, started at 4 px),
    never on medium ones, the finest level on wide ones (long clips: weakly seen turns reach the
    cost's rest instead of stalling where the initialisation put them). "narrow" (the default until
    session 38) leaves wide ones out too. Other values keep their meaning; anything else is refused."""
    from ycbvss.refine.bundle import RefineOptions, _ridge_levels, refine_scene

    assert RefineOptions().object_ridge == "by_baseline"
    got = {(v, g): _ridge_levels(v, g) for v in (False, True, "finest", "narrow", "by_baseline")
           for g in ("narrow", "medium", "wide")}
    assert [got[("by_baseline", g)] for g in ("narrow", "medium", "wide")] == ["every", "none", "finest"]
    assert [got[("narrow", g)] for g in ("narrow", "medium", "wide")] == ["every", "none", "none"]
    assert {got[(False, g)] for g in ("narrow", "medium", "wide")} == {"none"}
    assert {got[(True, g)] for g in ("narrow", "medium", "wide")} == {"every"}
    assert {got[("finest", g)] for g in ("narrow", "medium", "wide")} == {"finest"}
    # with the table holding the cameras' turn (table_flow), medium bundles get it at the finest level too
    assert [_ridge_levels("by_baseline", g, True) for g in ("narrow", "medium", "wide")] == ["every", "finest", "finest"]
    assert [_ridge_levels("narrow", g, True) for g in ("narrow", "medium", "wide")] == ["every", "none", "none"]
    from types import SimpleNamespace

    from ycbvss.errors import YcbvssError

    with pytest.raises(YcbvssError, match="scene 7: RefineOptions.object_ridge"):
        refine_scene(SimpleNamespace(scene_id=7), {}, {}, RefineOptions(object_ridge="wide"))


def test_slide_restart_goes_on_from_finer_levels(monkeypatch):
    """The slide restart's control flow (the passes faked): the first restart (from 4 px) still
    slides, the second (from 2 px) does not and is kept; when a restart slides a new object it is
    not kept and the first result stands."""
    from types import SimpleNamespace

    import ycbvss.refine.bundle as B

    def run(outcomes):
        calls = []

        def once(scene, models, init, opt, images):
            lv = tuple(opt.edge_sigmas_px or (8.0, 4.0, 2.0, 1.0))
            calls.append(lv)
            return SimpleNamespace(stats={"edge_sigmas_px": list(lv), "total_s": 1.0, "baseline_group": "medium",
                                          "slid": outcomes[lv], "ridge_fallback": [outcomes[lv]] if len(lv) == 4 else []},
                                   log=[{"stage": f"pass {lv}"}]), {}

        monkeypatch.setattr(B, "_refine_scene_once", once)
        monkeypatch.setattr(B, "_slid_objects", lambda res, width: res.stats["slid"])
        res, _ = B._refine_scene_pass(SimpleNamespace(frames=[]), {}, {}, B.RefineOptions(), None)
        return res, calls

    res, calls = run({(8.0, 4.0, 2.0, 1.0): [19], (4.0, 2.0, 1.0): [19], (2.0, 1.0): []})
    assert calls == [(8.0, 4.0, 2.0, 1.0), (4.0, 2.0, 1.0), (2.0, 1.0)]
    note = res.stats["slide_restart"]
    assert res.stats["edge_sigmas_px"] == [2.0, 1.0] and note["kept"] and note["levels_px"] == [2.0, 1.0]
    assert [a["kept"] for a in note["attempts"]] == [False, True] and res.stats["total_s"] == 3.0
    assert note["ridge_fallback"] == [[19]]       # the first pass's put-back objects, for the suite's rows
    assert [e["stage"] for e in res.log].count("slide restart") == 2

    res, calls = run({(8.0, 4.0, 2.0, 1.0): [19], (4.0, 2.0, 1.0): [19, 5], (2.0, 1.0): [5]})
    assert len(calls) == 3 and res.stats["edge_sigmas_px"] == [8.0, 4.0, 2.0, 1.0]
    assert not res.stats["slide_restart"]["kept"] and res.log[-1]["message"].endswith("first result stands")

    res, calls = run({(8.0, 4.0, 2.0, 1.0): [], (4.0, 2.0, 1.0): [], (2.0, 1.0): []})
    assert calls == [(8.0, 4.0, 2.0, 1.0)] and "slide_restart" not in res.stats


def test_objects_still_sliding_after_the_restarts_are_left_out_of_a_last_pass(monkeypatch):
    """_isolate_slid's bookkeeping (the passes faked): an object that still slid after every slide
    restart is left out and the scene refined once more; the others take that pass's poses and
    statuses, the left-out object keeps the first pass's pose, uncertain, confidence halved, the
    reason named. The last pass is not kept when fewer of the others converge in it."""
    from types import SimpleNamespace

    import ycbvss.refine.bundle as B
    from ycbvss.refine.options import RefineResult

    def shifted(dz):
        T = np.eye(4)
        T[2, 3] = 800.0 + dz
        return T

    def run(second_status, opt=None):
        calls = []

        def once(scene, models, init, opt, images):
            lv = tuple(opt.edge_sigmas_px or (8.0, 4.0, 2.0, 1.0))
            objs = sorted({k[1] for k in init})
            calls.append((lv, objs))
            full = 20 in objs
            dz = {3: -1.5, 6: -1.2, 20: -4.0} if full else {3: 0.2, 6: 0.5}
            poses = {(0, o): shifted(dz[o]) for o in objs}
            status = ({(0, 3): "converged", (0, 6): "uncertain", (0, 20): "uncertain"} if full
                      else {(0, 3): second_status, (0, 6): second_status})
            res = RefineResult(poses=poses, T_w2c={0: np.eye(4)}, T_m2w={o: poses[(0, o)] for o in objs},
                               init_poses=dict(init), sigma={"poses": {k: {"sigma_t_mm": np.ones(3)} for k in poses},
                                                             "objects": {}}, log=[{"stage": f"pass {lv} {objs}"}],
                               converged=True, visible=set(poses), status=status,
                               confidence={k: 0.8 for k in poses}, reasons={k: "" for k in poses},
                               quality={o: {"contour_px": 0.1} for o in objs},
                               stats={"edge_sigmas_px": list(lv), "total_s": 1.0, "baseline_group": "medium",
                                      "slid": [20] if full else [], "ridge_fallback": [[20]] if full and len(lv) == 4 else []})
            return res, {o: f"turn {o} {'full' if full else 'without'}" for o in objs}

        monkeypatch.setattr(B, "_refine_scene_once", once)
        monkeypatch.setattr(B, "_slid_objects", lambda res, width: res.stats["slid"])
        init = {(0, o): shifted(10.0) for o in (3, 6, 20)}
        return B._refine_scene_pass(SimpleNamespace(frames=[]), {}, init, opt or B.RefineOptions(), None), calls

    (res, turns), calls = run("converged")
    assert [c[1] for c in calls] == [[3, 6, 20]] * 3 + [[3, 6]]     # the pass, two restarts, the last pass
    assert res.poses[(0, 3)][2, 3] == 800.2 and res.poses[(0, 6)][2, 3] == 800.5
    assert res.poses[(0, 20)][2, 3] == 796.0 and res.status[(0, 20)] == "uncertain"
    assert res.confidence[(0, 20)] == pytest.approx(0.4) and "left out of the scene's final solution" in res.reasons[(0, 20)]
    assert res.status[(0, 6)] == "converged" and 20 not in res.missing_objects and 20 in res.T_m2w
    assert res.stats["isolate_slid"] == {"objects": [20], "kept": True, "converged_before": 1, "converged_after": 2,
                                         "total_s": 1.0}
    assert res.stats["total_s"] == 4.0 and res.stats["ridge_fallback"] == [[20]]
    assert turns[20] == "turn 20 full" and turns[3] == "turn 3 without"
    assert [e["stage"] for e in res.log].count("isolate slid") == 1

    (res, turns), calls = run("uncertain")       # one of the others converged before, none after
    assert len(calls) == 4 and res.poses[(0, 3)][2, 3] == 798.5 and not res.stats["isolate_slid"]["kept"]
    assert res.log[-1]["stage"] == "isolate slid" and res.log[-1]["message"].endswith("fewer of the other objects converged)")

    (res, _), calls = run("converged", B.RefineOptions(isolate_slid=False))     # off: no last pass
    assert len(calls) == 3 and "isolate_slid" not in res.stats and res.poses[(0, 3)][2, 3] == 798.5


def test_per_object_drift_is_a_steady_move_of_its_points():
    """_object_point_moves: an object's move (mm) as its centroid's displacement and its turn times
    its points' RMS radius, so a turn about its own centre reads as a turn, whatever its place in
    the world. _drifting_rows: an object drifts when it moves more than the limit in nearly the
    previous iteration's direction; the jitter of re-sampled terms (direction flipping) does not."""
    from ycbvss.geometry.so3 import exp_so3
    from ycbvss.refine.bundle import _drifting_rows, _object_point_moves, _rms_point_moves_mm
    from ycbvss.refine.problem import model_moments

    rng = np.random.default_rng(0)
    pts = rng.normal(scale=30.0, size=(500, 3)) + (5.0, -3.0, 10.0)
    mom = [model_moments(pts)] * 2
    c_m, C_m = mom[0]
    T_a = np.stack([np.eye(4), np.eye(4)])
    T_a[:, :3, 3] = (100.0, 0.0, 1200.0)
    T_b = T_a.copy()
    R = exp_so3(np.radians([0.0, 0.0, 0.5]))                 # object 0: 0.5 deg about its own centroid
    T_b[0, :3, :3] = R
    c_w = c_m + T_a[0, :3, 3]
    T_b[0, :3, 3] = c_w - R @ c_m
    T_b[1, :3, 3] += (0.3, 0.0, 0.0)                         # object 1: 0.3 mm sideways
    mv = _object_point_moves(T_a, T_b, mom)
    assert np.linalg.norm(mv[0, :3]) < 1e-9
    assert np.linalg.norm(mv[0, 3:]) == pytest.approx(np.radians(0.5) * np.sqrt(np.trace(C_m)), rel=1e-6)
    assert mv[1] == pytest.approx([0.3, 0, 0, 0, 0, 0])
    assert _drifting_rows(mv, mv, 0.1) == {0, 1}
    assert _drifting_rows(mv, -mv, 0.1) == set()              # jitter: the direction flips
    assert _drifting_rows(0.3 * mv, 0.3 * mv, 0.1) == {0}      # object 0 0.14 mm, object 1 only 0.09 mm
    # the RMS displacement of the points, against the points themselves
    far = _rms_point_moves_mm(T_a, T_b, mom)
    for j in range(2):
        d = pts @ T_b[j, :3, :3].T + T_b[j, :3, 3] - (pts @ T_a[j, :3, :3].T + T_a[j, :3, 3])
        assert far[j] == pytest.approx(np.sqrt(np.mean(np.sum(d ** 2, 1))), rel=1e-6)


def test_classify_a_pose_still_drifting_at_the_cap_is_uncertain():
    """A pose that was still sliding one way when the iteration cap ended the refinement has not
    converged, however small its last step against its sigma (suite medium-4, seed 5, with the
    table: the foam brick 15.9 deg off, 0.73 mm per iteration against sigma_add ~1.5 mm)."""
    from ycbvss.refine.confidence import DRIFT_REASON

    base = classify(0.3, 1.5, 0.73, True)
    drift = classify(0.3, 1.5, 0.73, True, drifting=True)
    assert base.status == "converged" and drift.status == "uncertain"
    assert DRIFT_REASON in drift.reason
    assert drift.confidence == pytest.approx(0.7 * base.confidence)


@pytest.mark.parametrize("fallback,slide_mm,finest,decay", [(True, 7.0, True, 1.0), (False, 7.0, True, 1.0),
                                                           (True, 1.0, True, 1.0), (True, 7.0, False, 1.0),
                                                           (True, 7.0, True, 0.8)])
def test_an_object_drifting_at_the_cap_runs_the_finest_level_again_with_the_stalling_ridge(monkeypatch, fallback,
                                                                                           slide_mm, finest, decay):
    """The finest level's control flow (its outer iterations faked): an object still drifting at
    the cap under the point-motion ridge goes back to the level's start and the level runs again
    with the world-origin ridge on that object only (RefineOptions.ridge_fallback); an object still
    drifting then is reported (drifting_objects -> status 'uncertain'). Without the fallback, or
    when the level carried the object less than ridge_fallback_mm (3 mm: a creep, not a runaway),
    the drifting object is reported at once; so too in a bundle with the point-motion ridge at every
    level (narrow baselines), where the stalled turn is no fallback, and for an object whose steps
    shrink (``decay`` 0.8 per iteration: a converging object, last 3 steps ~0.2 of its mean step
    over the 18 iterations, under ridge_fallback_speed 0.5; it is named in the stats instead).
    An object put back stays reported even when it no longer drifts in the repeat: the stalling
    ridge holds it where the coarse levels left it, which is no evidence of convergence."""
    import ycbvss.refine.bundle as B
    from ycbvss.refine.problem import BundleProblem, View, model_moments

    pts = np.random.default_rng(1).normal(scale=20.0, size=(200, 3))
    T_m = np.stack([np.eye(4), np.eye(4)])
    T_m[:, 2, 3] = 900.0
    pb = BundleProblem([View(0, np.eye(3), 640, 480)], [4, 9], np.eye(4)[None], T_m)
    st = object.__new__(B._Stage)
    st.pb, st.opt, st.stats, st.log = pb, B.RefineOptions(verify_coarse=False, ridge_fallback=fallback), {}, []
    st.term_views, st.ridge_finest, st.drifting_objects = [], finest, set()
    if not finest:
        pb.obj_moments = [model_moments(pts)] * 2    # the ridge at every level, set by the stage's setup
    st._light, st._flows, st._pending, st._lin_fields = {}, {}, {}, {}
    st.__dict__["moments"] = [model_moments(pts)] * 2
    calls = []

    def fake_iterate(fields, n_outer, n_cap, sopt, lam, sigma, n_built):
        calls.append((pb.T_m[0, 0, 3], [m is None for m in pb.obj_moments]))
        steps = slide_mm * decay ** np.arange(n_cap) * (1 - decay) / (1 - decay ** n_cap) if decay < 1 \
            else np.full(n_cap, slide_mm / n_cap)
        st.obj_steps_mm = [np.array([d, 0.0]) for d in steps]
        pb.T_m[0, 0, 3] += slide_mm                 # object 4 slides sideways in the first pass
        return False, ["term"], lam, n_cap - 1, {0} if len(calls) == 1 else set()

    monkeypatch.setattr(st, "_iterate", fake_iterate)
    st.run([1.0])
    if fallback and finest and slide_mm > st.opt.ridge_fallback_mm and decay == 1.0:
        # the second pass starts from the level's start, object 4 alone without the point-motion ridge
        assert calls == [(0.0, [False, False]), (0.0, [True, False])]
        assert st.stats["ridge_fallback"] == [[4]]
    else:
        assert calls == [(0.0, [False, False])] and "ridge_fallback" not in st.stats
        assert st.stats.get("ridge_fallback_slowing") == ([[4]] if decay < 1.0 else None)
    assert st.drifting_objects == {0}


def test_recent_speed_tells_a_runaway_from_a_converging_pose():
    """_recent_speed: last-3 mean step over the level's mean step, per object (column). The suite's
    cases (session 49): the large clamp's even-to-growing steps, the banana's shrinking ones."""
    from ycbvss.refine.bundle import _recent_speed

    clamp = np.r_[np.full(10, 0.3), np.full(8, 1.0)]            # 16.6 -> 27 mm, speeding up
    banana = 0.8 * 0.85 ** np.arange(18)                        # converging from 7 mm
    still = np.zeros(18)
    sp = _recent_speed(np.stack([clamp, banana, still], axis=1))
    assert sp[0] == pytest.approx(1.0 / clamp.mean())
    assert sp[0] > 1.5 and sp[1] < 0.25 and sp[2] == 0.0
    assert _recent_speed(np.zeros((0, 3))).tolist() == [np.inf] * 3
