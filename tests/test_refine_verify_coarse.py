"""The coarse-move check of the bundle's coarse-to-fine levels (``_Stage._verify_coarse_moves``):
per object, the finer level's edge cost picks the best of its current world pose and its poses at
the start of every earlier level. Pure logic: the edge cost is a stand-in function of the pose
(distance of the object's translation from where the finer level's edges fit it), no rendering."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ycbvss.refine.bundle import _Stage


def _T(x_mm: float) -> np.ndarray:
    T = np.eye(4)
    T[0, 3] = x_mm
    return T


def _stage(T_m_now: list[np.ndarray], best_x_mm: list[float]) -> _Stage:
    """A stage whose objects sit at ``T_m_now``; object j's finer-level edge cost grows with the
    distance of its x from ``best_x_mm[j]`` (NaN cost for an object marked without samples)."""
    st = _Stage.__new__(_Stage)
    st.pb = SimpleNamespace(obj_ids=list(range(len(T_m_now))), T_m=np.stack(T_m_now),
                            obj_known=np.ones(len(T_m_now), bool))
    st.opt = SimpleNamespace(pose_tol_mm=0.05, hold_hidden=True)
    st.stats = {}
    st.held_hidden = set()
    st.pb.obj_free = np.ones(len(T_m_now), bool)
    st.pb._index = lambda: None
    best = np.asarray(best_x_mm, float)
    st._object_edge_costs = lambda fields, keep=False: 1.0 - np.exp(-np.abs(st.pb.T_m[:, 0, 3] - best) / 20.0)
    return st


def test_an_object_goes_back_to_the_best_earlier_level_start():
    # object 0: init at 0 (right), after the 8 px level at 38, now at 77 -> back to the init
    # object 1: init at 0, coarse levels moved it to 20 (right): kept
    # object 2: init at 0, after the 8 px level at 10 (right), now at 30 -> back to the pose after
    #           the 8 px level (the 4 px level's start), the best of the three
    starts = [np.stack([_T(0), _T(0), _T(0)]), np.stack([_T(38), _T(15), _T(10)])]
    st = _stage([_T(77), _T(20), _T(30)], best_x_mm=[0.0, 20.0, 10.0])
    st._verify_coarse_moves(starts, fields={}, levels="2->1")
    x = st.pb.T_m[:, 0, 3]
    assert abs(x[0] - 0.0) < 1e-9 and abs(x[1] - 20.0) < 1e-9 and abs(x[2] - 10.0) < 1e-9, x
    rec = st.stats["coarse_moves_undone"][0]
    assert rec["obj_ids"] == [0, 2] and rec["to_level_start"] == [0, 1]


def test_an_object_that_did_not_move_or_has_no_cost_stays():
    starts = [np.stack([_T(0), _T(5)])]
    st = _stage([_T(0.01), _T(40)], best_x_mm=[3.0, 5.0])
    st._object_edge_costs = (lambda f, keep=False, base=st._object_edge_costs: np.where([True, False], base(f), np.nan))
    st._verify_coarse_moves(starts, fields={}, levels="8->4")
    # object 0 moved less than the pose tolerance; object 1 has no edge cost (no samples): both stay
    assert np.allclose(st.pb.T_m[:, 0, 3], [0.01, 40.0])
    assert "coarse_moves_undone" not in st.stats


def test_check_renders_serve_the_next_render_only_at_exactly_those_poses(monkeypatch):
    """``_Stage.render(i, keep=True)`` (the check's renders at the current poses) is handed to the
    next ``render(i)`` when the poses are still exactly the same, and re-rendered when an object
    has moved (render_view stubbed: counts calls)."""
    import ycbvss.refine.bundle as B

    calls = []
    monkeypatch.setattr(B, "render_view", lambda *a, **k: calls.append(a[6]) or object())
    st = _Stage.__new__(_Stage)
    st.pb = SimpleNamespace(obj_ids=[0, 1], obj_known=np.ones(2, bool), T_m=np.stack([_T(0.0), _T(5.0)]),
                            views=[SimpleNamespace(K=np.eye(3), width=4, height=3)])
    st.pb.pose = lambda i, j: st.pb.T_m[j].copy()
    st.opt, st.stats, st.renderer, st.models, st._pending = SimpleNamespace(edge_rim_depth=False), {}, None, {}, {}
    st._t = lambda k, v: None
    kept = st.render(0, keep=True)
    assert st.render(0) is kept and len(calls) == 1          # same poses: taken, not drawn again
    kept2 = st.render(0, keep=True)
    st.pb.T_m[1] = _T(5.001)
    assert st.render(0) is not kept2 and len(calls) == 3      # an object moved by 1 um: drawn again
    assert st._pending                                       # (left for the stage loop to clear)


def _hidden_beyond(st: _Stage, x_hidden_mm: float) -> None:
    """Object 0 shows no edge sample (NaN cost) once its x is beyond ``x_hidden_mm``."""
    base = st._object_edge_costs
    st._object_edge_costs = lambda f, keep=False: np.where(np.arange(len(st.pb.T_m)) == 0,
                                                           np.where(st.pb.T_m[:, 0, 3] > x_hidden_mm, np.nan, base(f)),
                                                           base(f))


def test_an_object_a_level_hid_goes_back_where_it_showed_and_is_held():
    # object 0: started at 0 (visible, cost 0.39 against its best at 10), a level threw it to 60,
    # where it is hidden in every view (no cost): back to 0 and no longer free; object 1 is untouched
    starts = [np.stack([_T(0), _T(0)])]
    st = _stage([_T(60), _T(0)], best_x_mm=[10.0, 0.0])
    _hidden_beyond(st, 30.0)
    st._verify_coarse_moves(starts, fields={}, levels="8->4")
    assert abs(st.pb.T_m[0, 0, 3]) < 1e-9 and st.held_hidden == {0}
    assert list(st.pb.obj_free) == [False, True]


def test_without_hold_hidden_a_hidden_object_keeps_its_pose():
    starts = [np.stack([_T(0), _T(0)])]
    st = _stage([_T(60), _T(0)], best_x_mm=[10.0, 0.0])
    st.opt.hold_hidden = False
    _hidden_beyond(st, 30.0)
    st._verify_coarse_moves(starts, fields={}, levels="8->4")
    assert abs(st.pb.T_m[0, 0, 3] - 60.0) < 1e-9 and not st.held_hidden and all(st.pb.obj_free)


def test_a_held_object_is_uncertain_with_its_reason():
    from ycbvss.refine.confidence import classify

    ok = classify(0.2, 0.5, 0.0, observed=True)
    held = classify(0.2, 0.5, 0.0, observed=True, held_hidden=True)
    assert ok.status == "converged" and held.status == "uncertain"
    assert "hid it in every view" in held.reason and abs(held.confidence - 0.5 * ok.confidence) < 1e-12


def test_a_held_object_whose_contour_is_off_fails_and_still_says_it_was_held():
    """A failed pose names its contour offset first and keeps the other findings (the hold)."""
    from ycbvss.refine.confidence import FAIL_PX, classify

    st = classify(FAIL_PX + 1.0, 0.5, 0.0, observed=True, held_hidden=True)
    assert st.status == "failed" and st.confidence <= 0.1
    assert st.reason.startswith(f"contour {FAIL_PX + 1.0:.2f} px off") and "hid it in every view" in st.reason
    plain = classify(FAIL_PX + 1.0, 0.5, 0.0, observed=True)
    assert plain.reason == f"contour {FAIL_PX + 1.0:.2f} px off the image edges"
