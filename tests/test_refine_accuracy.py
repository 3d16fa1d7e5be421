"""The issue's accuracy targets, end to end: the default demo scene (24 frames, 640x480, a 50 deg
camera arc, two textureless objects) rendered by Blender (an independent renderer: the refiner
only ever renders with the fast one), perturbed to the paper's initial error (mean ADD 22.1 mm,
PRJ 5.2 px), bundle-refined with all terms. Per-object mean targets (issue 9, baseline >= 20 deg):
tx, ty <= 0.25 mm, tz <= 0.8 mm, R <= 0.2 deg, PRJ <= 0.4 px.

Until session 36 tz was the one target the demo missed (can_stripes 0.798-0.809 mm: the free-camera
bundle's scale followed the sub-0.05 px edge lean of the sRGB-encoded render). Since the bias removal
on wide scenes (RefineOptions.bias_removal_groups) every object holds it with margin: on 2026-11-27
(session 38, `ycbvss demo`) tz 0.05-0.10 mm, R 0.02-0.10 deg, so it is asserted like the others.

Budget: about 1.5 min on 2 cores (Blender synthesis ~30 s, refinement ~40 s). Skipped without bpy."""
from __future__ import annotations

import csv
import importlib.util
import os

import pytest

TARGETS = {"tx (mm)": 0.25, "ty (mm)": 0.25, "tz (mm)": 0.8, "R (deg)": 0.2, "PRJ (px)": 0.4}


@pytest.fixture(scope="module")
def demo_rows(tmp_path_factory) -> dict:
    if importlib.util.find_spec("bpy") is None:
        pytest.skip("needs Blender (bpy)")
    from ycbvss.pipeline.demo import DemoOptions, run_demo
    from ycbvss.pipeline.validate import Stages

    os.environ["YCBVSS_NO_PROGRESS"] = "1"
    out = tmp_path_factory.mktemp("demo") / "demo"
    summary = run_demo(DemoOptions(out=out, ablation=False, overlays=0), Stages(quiet=True))
    assert abs(summary["initial"]["achieved_add_mm"] / 22.1 - 1) < 0.01
    with open(out / "tables" / "table4.csv", newline="") as fh:
        rows = {r["object"]: r for r in csv.DictReader(fh)}
    objects = [o for o in rows if o not in ("all", "initial") and not o.startswith(("paper", "YCBV", "binocular"))]
    assert len(objects) == 5 and sum(rows[o]["textureless"] == "1" for o in objects) == 2
    return {o: rows[o] for o in objects}


def test_demo_scene_meets_the_per_object_targets(demo_rows):
    misses = {(o, c): round(float(r[c]), 3) for o, r in demo_rows.items() for c, bound in TARGETS.items()
              if not float(r[c]) <= bound}
    assert not misses, misses
