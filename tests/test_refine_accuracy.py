"""The issue's accuracy targets, end to end: the default demo scene (24 frames, 640x480, a 50 deg
camera arc, two textureless objects) rendered by Blender (an independent renderer: the refiner
only ever renders with the fast one), perturbed to the paper's initial error (mean ADD 22.1 mm,
PRJ 5.2 px), bundle-refined with all terms. Every object -- the textureless box and mug included --
must reach the per-object mean targets tx, ty <= 0.25 mm, tz <= 0.8 mm, R <= 0.2 deg, PRJ <= 0.4 px.

Budget: about 1.5 min on 2 cores (Blender synthesis ~30 s, refinement ~40 s). Skipped without bpy."""
from __future__ import annotations

import csv
import importlib.util
import os

import pytest

TARGETS = {"tx (mm)": 0.25, "ty (mm)": 0.25, "tz (mm)": 0.8, "R (deg)": 0.2, "PRJ (px)": 0.4}


@pytest.mark.skipif(importlib.util.find_spec("bpy") is None, reason="needs Blender (bpy)")
def test_demo_scene_meets_the_per_object_targets(tmp_path):
    from ycbvss.pipeline.demo import DemoOptions, run_demo
    from ycbvss.pipeline.validate import Stages

    os.environ["YCBVSS_NO_PROGRESS"] = "1"
    out = tmp_path / "demo"
    summary = run_demo(DemoOptions(out=out, ablation=False, overlays=0), Stages(quiet=True))
    assert abs(summary["initial"]["achieved_add_mm"] / 22.1 - 1) < 0.01
    with open(out / "tables" / "table4.csv", newline="") as fh:
        rows = {r["object"]: r for r in csv.DictReader(fh)}
    objects = [o for o in rows if o not in ("all", "initial") and not o.startswith(("paper", "YCBV", "binocular"))]
    assert len(objects) == 5 and sum(rows[o]["textureless"] == "1" for o in objects) == 2
    misses = {(o, c): round(float(rows[o][c]), 3) for o in objects for c, bound in TARGETS.items()
              if not float(rows[o][c]) <= bound}
    assert not misses, misses
