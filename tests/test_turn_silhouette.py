"""An untextured object whose distinguishing part is hidden in every view (a plain mug's handle) can
turn about its body's axis without changing its silhouette: refine.turn_check measures that turn
about the axis of revolution, not about the bounding box's centre, which a handle moves off it. The
silhouettes are the fast renderer's, a geometry check only (no image is refined here)."""
import numpy as np
import pytest
import trimesh

from ycbvss.geometry.so3 import exp_so3
from ycbvss.refine.turn_check import (SAME_SILHOUETTE_PX2, TEXTURED_MIN, axis_turn_transforms, revolution_axes,
                                      same_silhouette_turn, silhouette_ambiguous, silhouette_change_px2,
                                      turn_transforms)


def _mug() -> trimesh.Trimesh:
    body = trimesh.creation.cylinder(radius=40.0, height=90.0, sections=96)     # axis: model z
    handle = trimesh.creation.box(extents=(24.0, 10.0, 50.0))
    handle.apply_translation((50.0, 0.0, 0.0))                                  # on +x
    return trimesh.util.concatenate([body, handle])


def test_the_axis_of_revolution_is_the_body_axis_not_the_box_centre():
    m = _mug()
    pts = revolution_axes(np.asarray(m.vertices))
    assert np.abs(pts[2, :2]).max() < 0.5                  # the body's axis (x, y) = (0, 0), mm
    assert 0.5 * (m.bounds[0, 0] + m.bounds[1, 0]) > 10.0   # the box centre lies 11 mm off it


def test_silhouette_change_counts_moved_parts_not_slivers():
    a = np.zeros((60, 60), bool)
    a[10:50, 10:50] = True
    sliver = a.copy()
    sliver[10:50, 50] = True                               # the outline one pixel out: tessellation
    assert silhouette_change_px2(a, sliver, 640) == 0.0
    blob = a.copy()
    blob[20:26, 50:56] = True                              # a part that moved out: 36 px
    assert silhouette_change_px2(a, blob, 640) == 36.0
    assert silhouette_change_px2(a, blob, 320) == 144.0    # px^2 at 640 px
    lab, px2 = same_silhouette_turn({"a": [36.0, 0.0], "b": [4.0, 2.0], "c": [float("nan")]})
    assert (lab, px2) == ("b", 4.0)
    assert silhouette_ambiguous(px2, 0.0) and not silhouette_ambiguous(px2, TEXTURED_MIN)
    assert not silhouette_ambiguous(SAME_SILHOUETTE_PX2 + 1.0, 0.0)


@pytest.fixture(scope="module")
def renderer():
    from ycbvss.render import Renderer
    r = Renderer()
    r.add_mesh("mug", _mug())
    return r


def _silhouette(r, T):
    K = np.array([[600.0, 0, 320.0], [0, 600.0, 240.0], [0, 0, 1]])
    return r.render(K, 640, 480, [("mug", T)], outputs=("instance",)).instance > 0


def _pose(handle_away: bool) -> np.ndarray:
    """The mug upright 700 mm in front of a camera 30 deg above it, its handle pointing away from the
    camera (hidden behind the body) or to the side."""
    T = np.eye(4)
    R_up = exp_so3(np.radians(-60.0) * np.array([1.0, 0.0, 0.0]))            # model z up, seen from 30 deg above
    R_handle = exp_so3(np.radians(90.0 if handle_away else 0.0) * np.array([0.0, 0.0, 1.0]))
    T[:3, :3] = R_up @ R_handle
    T[:3, 3] = (0.0, 0.0, 700.0)
    return T


def test_a_hidden_handle_leaves_the_turn_about_the_body_axis_unseen(renderer):
    m = _mug()
    V = np.asarray(m.vertices)
    axis_turns = dict(axis_turn_transforms(revolution_axes(V), None))
    box_turns = dict(turn_transforms(0.5 * (m.bounds[0] + m.bounds[1]), None))
    lab = "+20 deg about model z"
    hidden, side = _pose(True), _pose(False)
    # every turn about model z, the smallest change taken, as same_silhouette_turn does (at +-40 deg the
    # handle comes out from behind the body)
    ch_hidden = {l: [silhouette_change_px2(_silhouette(renderer, hidden), _silhouette(renderer, hidden @ A), 640)]
                 for l, A in axis_turns.items() if l.endswith("model z")}
    ch_box = {l: [silhouette_change_px2(_silhouette(renderer, hidden), _silhouette(renderer, hidden @ A), 640)]
              for l, A in box_turns.items() if l.endswith("model z")}
    ch_side = silhouette_change_px2(_silhouette(renderer, side), _silhouette(renderer, side @ axis_turns[lab]), 640)
    print("hidden handle, about the body axis", ch_hidden, "about the box centre", ch_box, "handle to the side", ch_side)
    assert min(v[0] for v in ch_box.values()) > 10 * SAME_SILHOUETTE_PX2   # the box centre's turns move the body
    assert ch_side > 10 * SAME_SILHOUETTE_PX2                              # a visible handle moves
    assert same_silhouette_turn(ch_hidden)[1] < SAME_SILHOUETTE_PX2         # a hidden one does not
