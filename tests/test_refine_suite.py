"""The CI-sized part of the refiner's validation suite (ycbv21-ci): five real YCB-V models (the
bowl, the textureless mug and foam brick, the thin marker, the large clamp) on a table, rendered by
Blender Cycles within this run (lit, glossy; the refiner's fast renderer draws only the table
under the objects, never an object), a short clip of 8 frames over about 7 degrees.

Bounds are the short-clip targets of the issue where they are met on this clip, and looser
stated bounds where they are not (measured values in the comments; the per-object table of the
whole suite is in the README). Budget: ~2 min on 2 cores. Skipped without bpy (fails under CI)."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

pytestmark = pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="needs Blender (bpy)")


@pytest.fixture(scope="module")
def suite_ci(tmp_path_factory, ycbv_root):
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import build_suite, clips_of

    root = tmp_path_factory.mktemp("suite_ci")
    models, specs = build_suite(ycbv_root, root, "ycbv21-ci", quiet=True)
    spec = specs[0]
    scene = load_bop_scene(root / "test", spec.scene_id, models)
    return models, scene, clips_of(spec)[0]


def _per_object(rows):
    out = {}
    for o in sorted({r["obj_id"] for r in rows}):
        ro = [r for r in rows if r["obj_id"] == o]
        out[o] = {k: float(np.mean([r[k] for r in ro])) for k in ("tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px", "add_mm",
                                                                    "init_add_mm", "dz_mm")}
        out[o]["status"] = [r["status"] for r in ro]
        out[o]["max_add_mm"] = max(r["add_mm"] for r in ro)
    return out


def test_suite_scene_is_what_the_issue_asks_for(suite_ci):
    import json

    models, scene, clip = suite_ci
    assert clip.kind == "short" and len(clip.im_ids) == 8
    dist = [np.linalg.norm(i.T_m2c[:3, 3]) for f in scene.frames for i in f.instances]
    assert 500 <= min(dist) and max(dist) <= 1600, (min(dist), max(dist))
    from ycbvss.refine.bundle import viewing_baseline_deg
    Tc = np.stack([f.T_w2c for f in sorted(scene.frames, key=lambda f: f.im_id)])
    Tm = np.stack([np.linalg.inv(scene.frames[0].T_w2c) @ i.T_m2c for i in scene.frames[0].instances])
    assert 4.0 <= viewing_baseline_deg(Tc, Tm) < 10.0
    info = json.loads((scene.frames[0].rgb_path.parents[1] / "scene_gt_info.json").read_text())
    assert all(0 < g["visib_fract"] <= 1 for g in info["0"])
    # the scene's marker names the images it rendered and the host that rendered them
    from ycbvss.io.provenance import rgb_sha256
    sdir = scene.frames[0].rgb_path.parents[1]
    marker = json.loads((sdir / "suite_scene.json").read_text())
    assert marker["rgb_sha256"] == rgb_sha256(sdir) and marker["rendered_on"]["cpu"]


def test_short_clip_from_the_papers_initial_error(suite_ci):
    from ycbvss.pipeline.suite_run import Run, run_one

    models, scene, clip = suite_ci
    rows = run_one(Run(clip, "paper", 0), scene, models)
    e = _per_object(rows)
    init = np.mean([r["init_add_mm"] for r in rows])
    assert 20.0 < init < 24.5, init                      # the paper's initial error (mean ADD 22.1 mm)
    for o, v in e.items():
        # measured (this clip, seed 0; lit templates on narrow bundles, 2026-11-26): tx <= 0.18, ty <= 0.26,
        # R <= 1.04 deg (foam brick), PRJ <= 0.47 px, tz <= 1.99 mm (large clamp 1.99, mug 1.89: the
        # short-clip target 1.5 mm is missed, see the README); before: 0.22 / 0.31 / 1.12 / 0.52 / 2.41
        assert v["tx_mm"] <= 0.4 and v["ty_mm"] <= 0.5 and v["prj_px"] <= 0.7, (o, v)
        assert v["tz_mm"] <= 3.5 and v["r_deg"] <= 1.6, (o, v)
        # no pose ends far off unless it is flagged
        bad = [s for r, s in zip([r for r in rows if r["obj_id"] == o], v["status"]) if r["add_mm"] > 10]
        assert all(s != "converged" for s in bad), (o, v)
    allv = {k: np.mean([v[k] for v in e.values()]) for k in ("tx_mm", "ty_mm", "tz_mm", "r_deg", "prj_px")}
    assert allv["tx_mm"] <= 0.3 and allv["ty_mm"] <= 0.3 and allv["prj_px"] <= 0.5, allv   # short-clip targets
    assert allv["tz_mm"] <= 2.5 and allv["r_deg"] <= 0.6, allv
    # honest confidence: the reported sigma (calibrated covariance + systematic floor) covers the
    # true error within 2 sigma for >= 90 % of the poses on every axis
    from ycbvss.pipeline.suite_report import coverage
    cov = {e: c["coverage"] for e, c in coverage(rows, calibrated=True).items()}
    print("coverage", cov)
    assert all(c >= 0.9 for c in cov.values()), cov


def test_bias_from_the_exact_ground_truth(suite_ci):
    """Started from the exact GT; measured (lit templates on narrow bundles, 2026-11-26): lateral <=
    0.28 mm, depth 0.27..1.97 mm (the mug), R <= 1.06 deg (foam brick); before: lateral <= 0.35,
    depth 0.16..2.82, R <= 1.13."""
    from ycbvss.pipeline.suite_run import Run, run_one

    models, scene, clip = suite_ci
    e = _per_object(run_one(Run(clip, "gt", 0), scene, models))
    for o, v in e.items():
        assert v["tx_mm"] <= 0.45 and v["ty_mm"] <= 0.45, (o, v)
        assert v["tz_mm"] <= 3.5 and v["r_deg"] <= 1.6, (o, v)


def test_known_cameras_reduce_the_depth_bias(suite_ci):
    """From the exact GT, the same clip with the cameras held at the GT (`--known-cameras`): much of
    the depth bias is the free-camera bundle's scene scale, which only the objects' apparent size
    fixes (bench/results/ycbv21/bias_sources.md). Measured (this clip, seed 0): mean tz over the
    five objects free 0.97 mm, known cameras 0.59 mm (ratio 0.61). With unlit templates on narrow
    bundles (the default before 2026-11-26, session 29) free 1.16, known 0.47 (ratio 0.41): the lit
    templates take part of f_point's pull off the free bundle's scale and leave the contours' own
    per-object depth bias, which known cameras do not remove."""
    from ycbvss.pipeline.suite_run import Run, run_one

    models, scene, clip = suite_ci
    free = _per_object(run_one(Run(clip, "gt", 0), scene, models))
    known = _per_object(run_one(Run(clip, "gt", 0), scene, models, {"fix_cameras": True}))
    tz_free = np.mean([v["tz_mm"] for v in free.values()])
    tz_known = np.mean([v["tz_mm"] for v in known.values()])
    assert tz_known <= 0.7 and tz_known < 0.75 * tz_free, (tz_free, tz_known)
    for o, v in known.items():
        assert v["tx_mm"] <= 0.2 and v["ty_mm"] <= 0.3 and v["tz_mm"] <= 1.5, (o, v)   # measured <= 0.11 / 0.15 / 1.22


def test_an_object_placed_far_along_its_ray_is_recovered_or_flagged(suite_ci):
    """A wrong but scene-consistent initialisation: the marker 60 mm farther along its ray in
    every view (the same world error), the others exact."""
    from ycbvss.eval.metrics import pose_errors
    from ycbvss.pipeline.suite import clip_scene
    from ycbvss.refine import RefineOptions, refine_scene

    models, scene, clip = suite_ci
    sc = clip_scene(scene, clip)
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in sc.frames for i in f.instances}
    init = {k: T.copy() for k, T in gt.items()}
    f0 = sc.frames[0]
    T0 = gt[(f0.im_id, 18)]
    T_far = T0.copy()
    T_far[:3, 3] *= 1.0 + 60.0 / np.linalg.norm(T0[:3, 3])          # along the first view's ray
    T_m2w = np.linalg.inv(f0.T_w2c) @ T_far
    for f in sc.frames:
        init[(f.im_id, 18)] = f.T_w2c @ T_m2w
    res = refine_scene(sc, models, init, RefineOptions(seed=0))
    keys = sorted(k for k in gt if k[1] == 18)
    E = pose_errors(np.stack([res.poses[k][:3, :3] for k in keys]), np.stack([res.poses[k][:3, 3] for k in keys]),
                    np.stack([gt[k][:3, :3] for k in keys]), np.stack([gt[k][:3, 3] for k in keys]),
                    np.stack([f0.camera.K] * len(keys)), models[18].vertices_mm, with_adds=False)
    for k, add in zip(keys, E["add_mm"]):
        assert add < 10.0 or res.status[k] != "converged", (k, add, res.status[k], res.reasons[k])


def test_an_object_turned_about_its_axis_is_recovered_by_its_texture(suite_ci):
    """A wrong but scene-consistent initialisation the silhouette cannot see: the marker turned 40 deg
    about its own (geometric symmetry) axis in every view, the others exact. The turned-copy texture
    check flags it (the default) and, with ``turn_restart``, finds the copy turned back and refines
    the scene once more from it (measured: R 43 deg flagged; 1.0 deg and ADD <= 0.6 mm restarted)."""
    from ycbvss.eval.metrics import pose_errors
    from ycbvss.geometry.model_frame import bbox_center
    from ycbvss.pipeline.suite import clip_scene
    from ycbvss.refine import RefineOptions, refine_scene
    from ycbvss.refine.turn_check import turn_transforms

    models, scene, clip = suite_ci
    sc = clip_scene(scene, clip)
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in sc.frames for i in f.instances}
    A = dict(turn_transforms(bbox_center(models[18].vertices_mm), None))["+40 deg about model y"]
    init = {k: (T @ A if k[1] == 18 else T.copy()) for k, T in gt.items()}
    keys = sorted(k for k in gt if k[1] == 18)

    def r_deg(res):
        return pose_errors(np.stack([res.poses[k][:3, :3] for k in keys]), np.stack([res.poses[k][:3, 3] for k in keys]),
                           np.stack([gt[k][:3, :3] for k in keys]), np.stack([gt[k][:3, 3] for k in keys]),
                           np.stack([sc.frames[0].camera.K] * len(keys)), models[18].vertices_mm)

    flagged = refine_scene(sc, models, init, RefineOptions(seed=0))
    assert r_deg(flagged)["r_deg"].min() > 30.0
    assert all(flagged.status[k] != "converged" and "fits the texture" in flagged.reasons[k] for k in keys)
    res = refine_scene(sc, models, init, RefineOptions(seed=0, turn_restart=True))
    E = r_deg(res)
    assert E["r_deg"].max() < 3.0 and E["add_mm"].max() < 2.0, (E["r_deg"], E["add_mm"])
    assert res.stats["turn_restart"]["18"]["kept"]
    assert all("fits the texture" not in res.reasons[k] for k in keys)


def _clip_views(suite_ci) -> tuple:
    """(models, the CI clip's views, their image loader, GT poses, obj_ids), meshes added to the renderer."""
    from ycbvss.pipeline.suite import clip_scene
    from ycbvss.refine import bundle as B
    from ycbvss.refine.templates import ensure_meshes, get_renderer

    models, scene, clip = suite_ci
    frames, views, imgs, _ = B._scene_views(clip_scene(scene, clip), None)
    gt = {(f.im_id, i.obj_id): i.T_m2c for f in frames for i in f.instances}
    ensure_meshes(get_renderer(), models)
    return models, views, imgs, gt, sorted({k[1] for k in gt})


def test_contour_check_reads_the_blender_images_at_the_exact_gt_and_off_it(suite_ci):
    """The status's contour measure on Cycles images (the template lit by the lighting fitted to
    each view): at the exact GT every object's worst views (:func:`worst_views_px`) stay under the
    1 px ``uncertain`` threshold; every object moved 4 mm along the camera x axis (about 3-4 px)
    in every view reads above it. Measured: at the GT 0.13-0.56 px (the large clamp 0.56), moved
    1.9-3.0 px."""
    from ycbvss.refine import evidence as Ev
    from ycbvss.refine.confidence import OK_PX

    models, views, imgs, gt, obj_ids = _clip_views(suite_ci)

    def worst(poses, lit):
        pv, lengths = Ev._contour_offsets_all_views(views, models, obj_ids, np.ones(len(obj_ids), bool), poses, imgs, lit=lit)
        return Ev._worst_views(pv, lengths, obj_ids)

    at_gt = worst(gt, lit=True)
    moved = {k: T.copy() for k, T in gt.items()}
    for T in moved.values():
        T[0, 3] += 4.0
    off = worst(moved, lit=True)
    for o in obj_ids:
        assert at_gt[o] < 0.8 * OK_PX, (o, at_gt)
        assert off[o] > OK_PX, (o, off)


def test_view_shift_reads_the_blender_images_at_the_exact_gt_and_off_it(suite_ci):
    """The status's per-view camera check (:mod:`ycbvss.refine.view_shift`) on Cycles images: at
    the exact GT every view reads 0 px; every object moved 8 mm along the camera x axis (a camera
    off by as much) reads about that many pixels; moved 30 mm, beyond the +-16 px reach, still
    well above the 3 px bound. Measured: 0 px; 9-10 px; ~16 px (4 mm: 4-5 px)."""
    from ycbvss.refine import evidence as Ev
    from ycbvss.refine.confidence import VIEW_SHIFT_PX
    from ycbvss.refine.view_shift import view_shift_px

    models, views, imgs, gt, obj_ids = _clip_views(suite_ci)

    def per_view(dx_mm):
        poses = {k: T.copy() for k, T in gt.items()}
        for T in poses.values():
            T[0, 3] += dx_mm
        sh: dict = {}
        Ev._contour_offsets_all_views(views, models, obj_ids, np.ones(len(obj_ids), bool), poses, imgs, shifts=sh)
        return np.array([view_shift_px(sh.get(i, {}).values()) for i in range(len(views))])

    at_gt, off8, off30 = per_view(0.0), per_view(8.0), per_view(30.0)
    assert np.all(at_gt <= 1.0), at_gt
    assert np.all((off8 >= 6.0) & (off8 <= 13.0)), off8
    assert np.all(off30 > 3 * VIEW_SHIFT_PX), off30
