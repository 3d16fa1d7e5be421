"""RefineOptions.bias_removal_groups, edge_rim_depth and supersample_groups: which scenes get
BIAS_REMOVAL, the rim-depth lift of the contour samples and area-integrated f_point templates
(refine.bundle._scene_options), and the second pass of a bundle whose refined cameras read another
group (refine.bundle._regroup)."""
from types import SimpleNamespace

from dataclasses import replace as dc_replace

import numpy as np
import pytest

from ycbvss.errors import YcbvssError
from ycbvss.refine import bundle as B
from ycbvss.refine.bundle import (BIAS_REMOVAL, RefineOptions, _bundle_min_sharpness, _KeyframeSolution, _regroup,
                                   _scene_options, refine_scene)


def _orbit(angles_deg: list[float], dist_mm: float = 1000.0) -> np.ndarray:
    """Cameras (world -> camera) on a circle about the origin, each looking at it."""
    T = []
    for a in np.radians(angles_deg):
        c = np.array([dist_mm * np.sin(a), 0.0, -dist_mm * np.cos(a)])     # camera centre
        z = -c / np.linalg.norm(c)
        x = np.cross([0.0, 1.0, 0.0], z)
        x /= np.linalg.norm(x)
        R = np.stack([x, np.cross(z, x), z])                                 # rows: camera axes in the world
        M = np.eye(4)
        M[:3, :3], M[:3, 3] = R, -R @ c
        T.append(M)
    return np.array(T)


def _pb(angles_deg):
    T_m = np.tile(np.eye(4), (3, 1, 1))
    T_m[:, :3, 3] = [[0, 0, 0], [80, 0, 0], [-60, 40, 0]]
    return SimpleNamespace(T_c=_orbit(angles_deg), T_m=T_m)


WIDE, MEDIUM, NARROW = [0, 20, 40, 60], [0, 10, 20], [0, 3, 6]     # baselines 60, 20, 6 deg


def _resolved(opt):
    """(group name, options, stats) of ``_scene_options`` on a wide, a medium and a narrow scene."""
    for name, angles in (("wide", WIDE), ("medium", MEDIUM), ("narrow", NARROW)):
        stats: dict = {}
        yield name, _scene_options(opt, _pb(angles), list(range(len(angles))), np.ones(3, bool), stats), stats


@pytest.mark.parametrize("groups, removed", [("medium,wide", {"wide", "medium"}), ("wide", {"wide"}),
                                             ("", set()), ("narrow", {"narrow"})])
def test_bias_removal_applies_to_the_scenes_of_its_baseline_groups_only(groups, removed):
    # edge_rim_depth, table_flow, table_contact and table_rest bools that stay, template_supersample 1: nothing else to resolve
    opt = RefineOptions(bias_removal_groups=groups, edge_rim_depth=False, template_supersample=1,
                        table_flow=False, table_contact=False, edge_across_only=False, axis_hold=False,
                        point_min_openness=0.0, edge_contact_mm=0.0, contact_weight=0.0, table_rest=False,
                        edge_contour_slide=False)
    for name, got, stats in _resolved(opt):
        assert stats["bias_removal"] is (name in removed)
        if name in removed:
            assert all(getattr(got, k) == v for k, v in BIAS_REMOVAL.items())
            assert any(getattr(opt, k) != v for k, v in BIAS_REMOVAL.items())     # the caller's options untouched
        else:
            assert got is opt


def test_the_free_standing_hold_resolves_by_the_scenes_baseline_group():
    got = {name: (o.table_rest_lean_mm, st["table_rest_lean_mm"]) for name, o, st in _resolved(RefineOptions())}
    assert got == {"wide": (0.0, 0.0), "medium": (0.0, 0.0), "narrow": (10.0, 10.0)}
    got = {name: o.table_rest_lean_mm for name, o, _ in _resolved(RefineOptions(table_rest_lean_groups="medium,wide"))}
    assert got == {"wide": 10.0, "medium": 10.0, "narrow": 0.0}
    # without the resting-face prior there is nothing to hold
    assert all(st["table_rest_lean_mm"] == 0.0 for _, _, st in _resolved(RefineOptions(table_rest=False)))


def test_edge_across_only_resolves_by_the_scenes_baseline_group():
    got = {name: (o.edge_across_only, st["edge_across_only"]) for name, o, st in _resolved(RefineOptions())}
    assert got == {"wide": (True, True), "medium": (True, True), "narrow": (False, False)}
    got = {name: o.edge_across_only for name, o, _ in _resolved(RefineOptions(edge_across_only="wide"))}
    assert got == {"wide": True, "medium": False, "narrow": False}


def test_axis_hold_resolves_by_the_scenes_baseline_group():
    got = {name: (o.axis_hold, st["axis_hold"]) for name, o, st in _resolved(RefineOptions())}
    assert got == {"wide": (False, False), "medium": (False, False), "narrow": (True, True)}
    got = {name: o.axis_hold for name, o, _ in _resolved(RefineOptions(axis_hold="medium,wide"))}
    assert got == {"wide": True, "medium": True, "narrow": False}


def test_contour_slide_resolves_by_the_scenes_baseline_group():
    got = {name: (o.edge_contour_slide, st["edge_contour_slide"]) for name, o, st in _resolved(RefineOptions())}
    assert got == {"wide": (True, True), "medium": (True, True), "narrow": (False, False)}
    got = {name: o.edge_contour_slide for name, o, _ in _resolved(RefineOptions(edge_contour_slide=False))}
    assert got == {"wide": False, "medium": False, "narrow": False}


def test_point_openness_resolves_by_the_scenes_baseline_group():
    got = {name: (o.point_min_openness, st["point_min_openness"]) for name, o, st in _resolved(RefineOptions())}
    assert got == {"wide": (0.0, 0.0), "medium": (0.5, 0.5), "narrow": (0.0, 0.0)}
    got = {name: o.point_min_openness for name, o, _ in
           _resolved(RefineOptions(point_min_openness=0.7, point_openness_groups="narrow,wide"))}
    assert got == {"wide": 0.7, "medium": 0.0, "narrow": 0.7}


def test_the_contact_pair_resolves_by_the_scenes_baseline_group():
    opt = RefineOptions()                                     # defaults: 10 mm and weight 1 on medium and wide bundles
    got = {name: (o.edge_contact_mm, o.contact_weight, st["edge_contact_mm"], st["contact_weight"])
           for name, o, st in _resolved(opt)}
    assert got == {"wide": (10.0, 1.0, 10.0, 1.0), "medium": (10.0, 1.0, 10.0, 1.0), "narrow": (0.0, 0.0, 0.0, 0.0)}
    assert (opt.edge_contact_mm, opt.contact_weight) == (10.0, 1.0)          # the caller's options untouched
    got = {name: o.contact_weight for name, o, _ in _resolved(dc_replace(opt, contact_groups=""))}
    assert got == {"wide": 0.0, "medium": 0.0, "narrow": 0.0}


@pytest.mark.parametrize("kw, match", [({"point_openness_groups": "mediun"}, "point_openness_groups"),
                                       ({"point_scale_groups": "wdie"}, "point_scale_groups"),
                                       ({"point_min_openness": 1.5}, "point_min_openness"),
                                       ({"point_min_openness": -0.1}, "point_min_openness"),
                                       ({"edge_table_mm": -1.0}, "edge_table_mm"),
                                       ({"edge_table_mm": float("nan")}, "edge_table_mm"),
                                       ({"edge_table_groups": "medim"}, "edge_table_groups"),
                                       ({"contact_groups": "wid"}, "contact_groups"),
                                       ({"edge_table_mm": 10.0, "edge_table_offset": True}, "edge_table_offset")])
def test_a_bad_point_openness_option_is_an_error_naming_it(kw, match):
    with pytest.raises(YcbvssError, match=match):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(**kw))


def test_an_unknown_axis_hold_group_is_an_error_naming_the_option():
    with pytest.raises(YcbvssError, match="axis_hold"):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(axis_hold="nraw"))


def test_the_default_removes_the_biases_on_medium_and_wide_scenes():
    assert RefineOptions().bias_removal_groups == "medium,wide"


def test_an_unknown_group_is_an_error_naming_the_option():
    with pytest.raises(YcbvssError, match="bias_removal_groups"):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(bias_removal_groups="wdie"))


def test_an_unknown_flow_prior_levels_is_an_error_naming_the_option():
    with pytest.raises(YcbvssError, match="flow_prior_levels"):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(flow_prior_levels="fine"))


@pytest.mark.parametrize("spec, on", [("wide", {"wide"}), ("medium,wide", {"medium", "wide"}), ("", set()),
                                      (True, {"wide", "medium", "narrow"}), (False, set())])
def test_rim_depth_is_resolved_per_scene_from_the_keyframes_baseline_group(spec, on):
    opt = RefineOptions(edge_rim_depth=spec)
    for name, got, stats in _resolved(opt):
        assert got.edge_rim_depth is (name in on)          # always a bool after resolution
        assert stats["edge_rim_depth"] is (name in on)
    assert opt.edge_rim_depth == spec                       # the caller's options untouched


def test_the_default_lifts_contour_samples_at_the_rim_on_wide_scenes_only():
    assert RefineOptions().edge_rim_depth == "wide"


def test_an_unknown_rim_depth_group_is_an_error_naming_the_option():
    with pytest.raises(YcbvssError, match="edge_rim_depth"):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(edge_rim_depth="long"))


@pytest.mark.parametrize("spec, on", [("wide", {"wide"}), ("medium,wide", {"medium", "wide"}), ("", set()),
                                      ("narrow,medium,wide", {"wide", "medium", "narrow"})])
def test_template_supersample_is_resolved_per_scene_from_the_keyframes_baseline_group(spec, on):
    opt = RefineOptions(supersample_groups=spec, template_supersample=3)
    for name, got, stats in _resolved(opt):
        assert got.template_supersample == (3 if name in on else 1)
        assert stats["template_supersample"] == got.template_supersample
    assert opt.template_supersample == 3                        # the caller's options untouched


def test_the_default_supersamples_medium_and_wide_scenes_at_2():
    assert (RefineOptions().template_supersample, RefineOptions().supersample_groups) == (2, "medium,wide")


@pytest.mark.parametrize("bad", [0, 2.5, "2", 9])
def test_a_bad_template_supersample_is_an_error_naming_the_option(bad):
    with pytest.raises(YcbvssError, match="template_supersample"):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(template_supersample=bad))


@pytest.mark.parametrize("bad", [-1.0, float("nan"), "10", None, True])
def test_a_bad_edge_contact_mm_is_an_error_naming_the_option(bad):
    with pytest.raises(YcbvssError, match="edge_contact_mm"):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(edge_contact_mm=bad))


@pytest.mark.parametrize("name", ["contact_weight", "contact_tol_mm", "table_weight"])
@pytest.mark.parametrize("bad", [-0.5, float("inf"), "1", None, False])
def test_a_bad_contact_option_is_an_error_naming_it(name, bad):
    with pytest.raises(YcbvssError, match=name):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(**{name: bad}))


@pytest.mark.parametrize("kw", [dict(table_flow="rotation"), dict(table_flow=1), dict(table_levels="coarse"), dict(table_points=10),
                                dict(table_points=500.0), dict(table_points=True), dict(table_span_deg=-1.0),
                                dict(table_span_deg=float("nan")), dict(table_span_deg="30"),
                                dict(ridge_fallback_mm=-1.0), dict(ridge_fallback_speed=float("nan")), dict(table_contact_sigma_mm=0.0),
                                dict(table_contact_sigma_mm=float("inf")), dict(table_contact_sigma_mm="0.5"),
                                dict(table_contact_normal_deg=0.0), dict(table_contact_normal_deg=float("nan")),
                                dict(table_contact="long"), dict(table_rest="long"), dict(table_rest=1),
                                dict(table_rest_acc_mm=0.0), dict(table_rest_acc_mm=float("nan")), dict(table_rest_acc_mm="1"),
                                dict(table_rest_stacked="yes")])
def test_a_bad_table_option_is_an_error_naming_it(kw):
    with pytest.raises(YcbvssError, match=next(iter(kw))):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(**kw))


@pytest.mark.parametrize("spec, on", [("medium", {"medium"}), ("medium,wide", {"medium", "wide"}), ("", set()),
                                      (True, {"wide", "medium", "narrow"}), (False, set())])
def test_table_flow_is_resolved_per_scene_from_the_keyframes_baseline_group(spec, on):
    opt = RefineOptions(table_flow=spec)
    for name, got, stats in _resolved(opt):
        assert got.table_flow is (name in on)
        assert stats["table_flow"] is (name in on)
    assert opt.table_flow == spec


@pytest.mark.parametrize("flow, contact, on", [("medium", True, {"medium"}), ("medium", False, set()),
                                               (False, True, set()), ("medium", "narrow,medium", {"narrow", "medium"}),
                                               (False, "narrow", {"narrow"}), ("wide", "", set())])
def test_table_contact_is_resolved_per_scene_with_or_without_the_table_flow(flow, contact, on):
    # True: wherever the rotation term is; a group list: on those groups' scenes whatever table_flow is
    opt = RefineOptions(table_flow=flow, table_contact=contact)
    for name, got, stats in _resolved(opt):
        assert got.table_contact is (name in on)
        assert stats["table_contact"] is (name in on)
    assert opt.table_contact == contact


@pytest.mark.parametrize("contact, rest, on", [("narrow,medium", "narrow,medium", {"narrow", "medium"}),
                                               ("medium", "narrow,medium", {"medium"}), ("narrow,medium", True, {"narrow", "medium"}),
                                               ("narrow,medium", False, set()), (False, True, set())])
def test_table_rest_is_resolved_per_scene_and_only_with_table_contact(contact, rest, on):
    opt = RefineOptions(table_contact=contact, table_rest=rest)
    for name, got, stats in _resolved(opt):
        assert got.table_rest is (name in on)
        assert stats["table_rest"] is (name in on)


def test_the_default_holds_the_rest_faces_on_every_scene_with_table_contact():
    got = {name: o.table_rest for name, o, _ in _resolved(RefineOptions())}
    assert got == {"wide": True, "medium": True, "narrow": True}


def test_an_unknown_table_flow_group_is_an_error_naming_the_option():
    with pytest.raises(YcbvssError, match="table_flow"):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(table_flow="long"))


@pytest.mark.parametrize("spec, on", [("narrow", {"narrow"}), ("narrow,medium", {"narrow", "medium"}),
                                      ("all", {"narrow", "medium", "wide"}), ("", set())])
def test_the_sharpness_gate_is_resolved_per_keyframe_bundle_from_its_baseline_group(spec, on):
    opt = RefineOptions(interior_sharpness_bundles=spec, interior_min_sharpness=1.8)
    for group in ("narrow", "medium", "wide"):
        assert _bundle_min_sharpness(opt, group) == (1.8 if group in on else 0.0)


def test_an_unknown_sharpness_bundle_group_is_an_error_naming_the_option():
    with pytest.raises(YcbvssError, match="interior_sharpness_bundles"):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(interior_sharpness_bundles="long"))


def test_the_contact_offset_and_the_dilation_nuisance_cannot_both_be_on():
    with pytest.raises(YcbvssError, match="edge_contact_offset_k"):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {},
                     RefineOptions(edge_contact_offset_k=1.0, edge_dilation_k=5.0))
    with pytest.raises(YcbvssError, match="one contour nuisance per group"):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {},
                     RefineOptions(edge_contact_offset_k=1.0, edge_shift_k=3.0))


@pytest.mark.parametrize("name", ["edge_contact_offset_k", "contact_offset_mm"])
def test_a_bad_contact_offset_option_is_an_error_naming_it(name):
    with pytest.raises(YcbvssError, match=name):
        refine_scene(SimpleNamespace(scene_id=7, frames=[]), {}, {}, RefineOptions(**{name: -1.0}))


# RefineOptions.regroup: a keyframe bundle whose refined cameras read another baseline group than
# its initial cameras is refined again as that group, and the second pass is kept only when its own
# refined cameras confirm it (refine.bundle._regroup). The refinement itself is replaced by a
# stand-in that returns cameras of a chosen baseline, so the decision is tested on its own.


def _solution(angles_deg: list[float], group: str) -> _KeyframeSolution:
    pb = _pb(angles_deg)
    return _KeyframeSolution(pb.T_c, pb.T_m, SimpleNamespace(), group == "narrow", set(), {}, {}, {}, group=group)


def _run(monkeypatch, first_angles, second_angles, first_group="medium"):
    """_regroup after a first pass refined as ``first_group`` whose cameras read ``first_angles``;
    a second pass, if asked for, returns cameras of ``second_angles``. Returns (solution, stats,
    log, groups the stand-in was asked to refine as)."""
    asked = []

    def fake_refine_keyframes(views, models, obj_ids, known, pb0, kf, opt, log, stats, imgs, group=None):
        asked.append(group)
        stats["pass"] = "second"
        log.append({"stage": "keyframes", "message": "second pass"})
        return _solution(second_angles, group)

    monkeypatch.setattr(B, "_refine_keyframes", fake_refine_keyframes)
    opt = RefineOptions()
    pb0 = _pb(first_angles)
    known, kf = np.ones(3, bool), list(range(len(first_angles)))
    stats0: dict = {"n_views": len(kf)}
    stats = dict(stats0, **{"pass": "first"})
    log: list = []
    ks, _ = _regroup([], {}, [1, 2, 3], known, pb0, kf, opt, opt, _solution(first_angles, first_group), log, stats,
                     stats0, None)
    return ks, stats, log, asked


def test_a_bundle_its_refined_cameras_confirm_is_not_refined_again(monkeypatch):
    for angles, group in ((NARROW, "narrow"), (MEDIUM, "medium"), (WIDE, "wide")):
        ks, stats, log, asked = _run(monkeypatch, angles, angles, group)
        assert asked == [] and stats["regroup"] is None and stats["pass"] == "first" and log == []
        assert ks.group == group


def test_refined_again_as_the_group_the_refined_cameras_read_and_kept_when_confirmed(monkeypatch):
    # refined as medium (scattered initial cameras), the refined cameras read 6 deg: narrow
    ks, stats, log, asked = _run(monkeypatch, NARROW, NARROW, "medium")
    assert asked == ["narrow"]
    assert ks.group == "narrow" and ks.narrow
    assert stats["pass"] == "second"
    note = stats["regroup"]
    assert note["first"] == "medium" and note["second"] == "narrow" and note["kept"] is True
    assert abs(note["first_refined_deg"] - 6.0) < 0.01 and abs(note["second_refined_deg"] - 6.0) < 0.01
    assert log[0]["stage"] == "regroup" and "kept" in log[0]["message"] and log[1]["message"] == "second pass"


def test_the_first_pass_stands_when_the_second_does_not_confirm_its_group(monkeypatch):
    # the second pass (as narrow) ends with cameras that read medium again
    ks, stats, log, asked = _run(monkeypatch, NARROW, MEDIUM, "medium")
    assert asked == ["narrow"]
    assert ks.group == "medium" and stats["pass"] == "first"
    assert stats["regroup"]["kept"] is False and stats["regroup"]["second"] == "narrow"
    assert len(log) == 1 and "not kept" in log[0]["message"]


def test_scene_options_resolve_a_given_group_instead_of_the_cameras_reading():
    opt = RefineOptions(edge_across_only="medium,wide", axis_hold="narrow")
    pb = _pb(MEDIUM)                      # the cameras read 20 deg
    kf, known = list(range(len(MEDIUM))), np.ones(3, bool)
    as_read = _scene_options(opt, pb, kf, known, {})
    as_narrow = _scene_options(opt, pb, kf, known, {}, group="narrow")
    assert as_read.edge_across_only is True and as_read.axis_hold is False
    assert as_narrow.edge_across_only is False and as_narrow.axis_hold is True


def test_orbit_baselines_used_here():
    T_m = _pb(NARROW).T_m
    for angles, deg in ((NARROW, 6.0), (MEDIUM, 20.0), (WIDE, 60.0)):
        assert abs(B.viewing_baseline_deg(_orbit(angles), T_m) - deg) < 0.5


# RefineOptions.sweep_again: a keyframe bundle that the finest level's iteration cap ended with
# objects still drifting one way runs its blur levels once more (refine.bundle._sweep). The stage is
# a stand-in that records its runs and reports which objects drift after each.
class _SweepStage:
    def __init__(self, drifts):
        self.drifts, self.runs, self.drifting_objects = list(drifts), [], set()

    def run(self, levels):
        self.runs.append(tuple(levels))
        self.drifting_objects = set(self.drifts.pop(0))
        return [f"terms of run {len(self.runs)}"]


def test_sweep_runs_the_levels_again_only_when_objects_still_drift():
    from ycbvss.refine.bundle import _sweep

    levels = (8.0, 4.0, 2.0, 1.0)
    stage, stats, log = _SweepStage([set()]), {}, []
    assert _sweep(stage, levels, True, [1, 5, 8], stats, log) == ["terms of run 1"]
    assert stage.runs == [levels] and stats["sweep_again"] is None and log == []        # finished: one sweep

    stage, stats, log = _SweepStage([{0, 2}, set()]), {}, []
    assert _sweep(stage, levels, True, [1, 5, 8], stats, log) == ["terms of run 2"]
    assert stage.runs == [levels, levels]
    assert stats["sweep_again"] == {"drifting_after_first": [1, 8], "drifting_after_second": []}
    assert log[0]["stage"] == "sweep_again" and "[1, 8]" in log[0]["message"]
    assert stage.drifting_objects == set()                                            # the status reads the second

    stage, stats, log = _SweepStage([{1}, {1}]), {}, []
    _sweep(stage, levels, True, [1, 5, 8], stats, log)
    assert len(stage.runs) == 2 and stats["sweep_again"]["drifting_after_second"] == [5]   # at most once more
    assert stage.drifting_objects == {1}                                              # still flagged

    stage, stats, log = _SweepStage([{0}]), {}, []
    _sweep(stage, levels, False, [1, 5, 8], stats, log)                               # option off
    assert len(stage.runs) == 1 and stats["sweep_again"] is None and stage.drifting_objects == {0}
