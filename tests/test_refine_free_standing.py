"""An object with nothing to lean on rests on a face (``RefineOptions.table_rest_lean_mm``), on the
clip where that was found: ``ycbv21-fresh2`` short-44, rendered by Blender Cycles within this run
(34 frames of scene 44, ~1 min on 2 cores). Its large marker lies pointing away from the camera,
the black cap's end almost without an edge against the brown table. Measured (session 75, seed 0,
paper init): with the let-go kernel the marker ends 17 mm too near and 9.5 deg lifted (ADD 18.3 mm,
`uncertain`); held on its face, ADD 0.4 mm. Skipped without bpy (fails under CI)."""
from __future__ import annotations

import importlib.util

import numpy as np
import pytest

pytestmark = pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="needs Blender (bpy)")

MARKER = 18


@pytest.fixture(scope="module")
def short44(tmp_path_factory, ycbv_root):
    from ycbvss.io.bop import load_bop_scene
    from ycbvss.pipeline.suite import build_suite, clips_of

    root = tmp_path_factory.mktemp("suite_fresh2_44")
    models, specs = build_suite(ycbv_root, root, "ycbv21-fresh2", scene_ids=[44], quiet=True)
    scene = load_bop_scene(root / "test", 44, models)
    clip = next(c for c in clips_of(specs[0]) if c.kind == "short")
    return models, scene, clip


def _marker_rows(short44, options: dict | None = None) -> list[dict]:
    from ycbvss.pipeline.suite_run import Run, run_one

    models, scene, clip = short44
    return [r for r in run_one(Run(clip, "paper", 0), scene, models, options) if r["obj_id"] == MARKER]


def test_a_free_standing_marker_is_held_on_its_face(short44):
    rows = _marker_rows(short44)
    assert len(rows) == 8
    add = np.array([r["add_mm"] for r in rows])
    assert add.max() < 2.0, add                                   # measured 0.4 mm
    assert np.mean([r["tz_mm"] for r in rows]) < 1.0


def test_let_go_the_same_marker_ends_centimetres_off_and_is_flagged(short44):
    rows = _marker_rows(short44, {"table_rest_lean_mm": 0.0})
    add = np.array([r["add_mm"] for r in rows])
    assert add.min() > 10.0, add                                   # measured 18.3 mm
    assert all(r["status"] != "converged" for r in rows)
