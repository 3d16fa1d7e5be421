"""`--symmetric paper|bop|posecnn|none|IDS`: the sets, their names, and the name in the table headers."""
from __future__ import annotations

import pytest

from ycbvss.errors import YcbvssError
from ycbvss.eval.symmetric_sets import parse_symmetric


def test_presets_and_ids():
    assert parse_symmetric(None) == ((13,), "paper")
    assert parse_symmetric(["bop"]) == ((1, 13, 14, 16, 18, 19, 20, 21), "bop")
    assert parse_symmetric(["posecnn"]) == ((13, 16, 19, 20, 21), "posecnn")
    assert parse_symmetric([]) == ((), "none")
    assert parse_symmetric(["21", "13,16", "19", "20"]) == ((13, 16, 19, 20, 21), "posecnn")
    assert parse_symmetric(["13", "2"]) == ((2, 13), "ids 2,13")
    with pytest.raises(YcbvssError):
        parse_symmetric(["bowl"])


def test_set_named_in_table_headers():
    import numpy as np
    from ycbvss.eval.evaluate import EstArrays, EvalOptions, GtArrays, evaluate_arrays
    from ycbvss.eval.outputs import summary_text
    from ycbvss.scene import ObjectModel
    pts = np.random.default_rng(0).normal(size=(200, 3)) * 30.0
    models = {}
    for o in (2, 13):
        models[o] = ObjectModel(obj_id=o, name=f"{o:03d}_thing")
        models[o].__dict__["vertices_mm"] = pts       # cached_property override
    K = np.array([[600, 0, 320], [0, 600, 240], [0, 0, 1.0]])
    R = np.repeat(np.eye(3)[None], 2, 0)
    t = np.array([[0, 0, 800.0], [50, 0, 900.0]])
    gt = GtArrays(np.zeros(2, int), np.zeros(2, int), np.array([13, 2]), np.arange(2), R, t, np.repeat(K[None], 2, 0))
    est = EstArrays(np.zeros(2, int), np.zeros(2, int), np.array([13, 2]), np.ones(2), R, t + 1.0)
    ids, label = parse_symmetric(["bop"])
    res = evaluate_arrays(gt, est, models, EvalOptions(symmetric_obj_ids=ids, symmetric_set=label))
    txt = summary_text(res)
    assert "ADD(-S) AUC [bop]" in txt and "ADD-S set: bop (1, 13, 14, 16, 18, 19, 20, 21)" in txt
    assert res.summary["options"]["symmetric_set"] == "bop"
