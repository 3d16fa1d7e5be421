"""refine.support: an object that rests on nothing (its lowest point off the table and its surface off
every other object) is found, and classify makes its pose uncertain (RefineOptions.support_check)."""
import numpy as np
import trimesh

from ycbvss.geometry.so3 import exp_so3
from ycbvss.refine.confidence import UNSUPPORTED_MM, classify
from ycbvss.refine.contact import contact_surface
from ycbvss.refine.support import nearest_gap_mm, unsupported_mm


def _table_scene(lift_mm=0.0, stack=True):
    """Six boxes on the plane z = 0 of a table frame tilted toward a camera 1 m away (world = the
    camera's frame); box 3 lies on box 2 when ``stack``; box 0 is lifted ``lift_mm`` along the table
    normal. Returns (T_m (6, 4, 4), hull vertices, contact surfaces, camera centres)."""
    exts = [(60.0, 40, 100), (80, 80, 30), (120, 90, 40), (50, 50, 20), (70, 30, 60), (40, 40, 40)]
    places = [(-200.0, 0, 50), (150, 60, 15), (20, -150, 20), (20, -150, 50), (-50, 200, 30), (250, -120, 20)]
    if not stack:
        places[3] = (-60.0, 160, 10)
    R_t = exp_so3(np.radians([-140.0, 0, 0]))
    T_t = np.eye(4)
    T_t[:3, :3], T_t[:3, 3] = R_t, (0.0, 0.0, 1000.0)
    meshes = [trimesh.creation.box(e) for e in exts]
    T_m = []
    for k, (x, y, z) in enumerate(places):
        T = np.eye(4)
        T[:3, 3] = (x, y, z + (lift_mm if k == 0 else 0.0))
        T_m.append(T_t @ T)
    hulls = [np.asarray(m.vertices, float) for m in meshes]
    surfaces = [contact_surface(m) for m in meshes]
    return np.stack(T_m), hulls, surfaces, np.zeros((1, 3))


def test_objects_at_rest_are_supported_and_a_lifted_one_is_not():
    T_m, hulls, surfaces, C = _table_scene()
    rest = unsupported_mm(T_m, hulls, surfaces, C, [0, 1, 2, 3, 4, 5])
    for j in (0, 1, 2, 4, 5):              # on the table
        assert abs(rest[j]["height_mm"]) < 0.01
        assert rest[j]["unsupported_mm"] < 0.01
    # the stacked box is 40 mm above the table but touches the box beneath it (gap: sample spacing only)
    assert abs(rest[3]["height_mm"] - 40.0) < 0.01
    assert rest[3]["gap_mm"] < 2.0
    assert rest[3]["unsupported_mm"] < 2.0
    T_m, hulls, surfaces, C = _table_scene(lift_mm=5.0)
    up = unsupported_mm(T_m, hulls, surfaces, C, [0, 1, 2, 3, 4, 5])
    assert abs(up[0]["height_mm"] - 5.0) < 0.01           # 5 mm above the plane the other three define
    assert up[0]["gap_mm"] > 100.0                          # nothing beside it
    assert up[0]["unsupported_mm"] > UNSUPPORTED_MM
    assert max(up[j]["unsupported_mm"] for j in (1, 2, 4, 5)) < 0.01      # the lifted box does not tilt their table
    assert up[3]["unsupported_mm"] < 2.0


def test_the_table_needs_three_objects_touching_it():
    T_m, hulls, surfaces, C = _table_scene(stack=False)
    two = unsupported_mm(T_m[:2], hulls[:2], surfaces[:2], C, [0, 1])
    assert all(np.isnan(v["unsupported_mm"]) for v in two.values())
    three = unsupported_mm(T_m[:3], hulls[:3], surfaces[:3], C, [0, 1, 2])
    assert all(abs(v["unsupported_mm"]) < 0.01 for v in three.values())
    # box 0 lifted beside three boxes on the table: the table is theirs, not a facet tilted to touch box 0
    T_up = _table_scene(lift_mm=5.0, stack=False)[0]
    up = unsupported_mm(T_up[:4], hulls[:4], surfaces[:4], C, [0, 1, 2, 3])
    assert up[0]["unsupported_mm"] > UNSUPPORTED_MM
    assert all(not up[j]["unsupported_mm"] > 1.0 for j in (1, 2, 3)), [up[j] for j in (1, 2, 3)]
    # a NaN pose is left out, not measured
    T_bad = T_m.copy()
    T_bad[2] = np.nan
    part = unsupported_mm(T_bad, hulls, surfaces, C, [0, 1, 2, 3, 4, 5])
    assert np.isnan(part[2]["unsupported_mm"]) and np.isfinite(part[0]["unsupported_mm"])


def test_nearest_gap_measures_the_distance_between_surfaces():
    T_m, hulls, surfaces, C = _table_scene(stack=False)
    # box 0 (60 wide along x, centre x = -200) and box 1 (80 wide, centre 150): faces 280 mm apart
    # along x, box 1 60 mm off in y within box 0's 40 mm depth -> a corner gap of sqrt(280^2 + 20^2)
    g = nearest_gap_mm(T_m, surfaces, 0, [1])
    assert abs(g - np.hypot(280.0, 20.0)) < 3.0


def test_classify_makes_a_pose_resting_on_nothing_uncertain():
    ok = classify(0.14, 1.8, 0.05, True, unsupported_mm=0.4)
    assert ok.status == "converged"
    floating = classify(0.14, 1.8, 0.05, True, unsupported_mm=5.0)
    assert floating.status == "uncertain"
    assert "rests on nothing" in floating.reason
    assert abs(floating.confidence - 0.5 * ok.confidence) < 1e-9
    assert classify(0.14, 1.8, 0.05, True).status == "converged"      # not measured: no verdict


def test_an_object_refined_into_the_table_does_not_lift_the_others():
    T_m, hulls, surfaces, C = _table_scene(lift_mm=-5.0)          # box 0 sunk 5 mm into the table
    r = unsupported_mm(T_m, hulls, surfaces, C, [0, 1, 2, 3, 4, 5])
    assert abs(r[0]["height_mm"] + 5.0) < 0.01
    assert max(r[j]["unsupported_mm"] for j in (1, 2, 4, 5)) < 0.01
