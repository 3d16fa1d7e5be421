"""bench/suite_rows_sigma_add.py: older suite rows get the sigma_add_mm column the refiner records now,
computed as the refiner does, every other column untouched; the report then widens their
non-converged poses."""
import csv
import gzip
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import trimesh

from ycbvss.pipeline.suite_report import row_sigmas
from ycbvss.pipeline.suite_run import read_rows
from ycbvss.refine.confidence import sigma_add_mm, sigma_scale

BENCH = Path(__file__).parents[1] / "bench" / "suite_rows_sigma_add.py"


def test_backfilled_column_is_the_refiners_sigma_add(tmp_path):
    models = tmp_path / "models"
    models.mkdir()
    box = trimesh.creation.box(extents=(40.0, 60.0, 80.0))           # mm
    box.export(models / "obj_000005.ply")
    radius = float(np.linalg.norm(box.vertices, axis=1).mean())
    fields = ["clip", "kind", "scene_id", "held_out", "init", "seed", "variant", "im_id", "obj_id", "tx_mm", "ty_mm",
              "tz_mm", "r_deg", "sigma_tx_mm", "sigma_ty_mm", "sigma_tz_mm", "sigma_r_deg", "status", "reason"]
    rows = [{"clip": "short-3", "kind": "short", "scene_id": 3, "held_out": 0, "init": "paper", "seed": 0,
             "variant": "using all", "im_id": i, "obj_id": 5, "tx_mm": 0.1, "ty_mm": 2.8, "tz_mm": 1.0, "r_deg": 0.3,
             "sigma_tx_mm": 0.1, "sigma_ty_mm": 0.1, "sigma_tz_mm": 1.5 + i, "sigma_r_deg": 0.2,
             "status": "uncertain" if i else "converged", "reason": ""} for i in range(2)]
    src = tmp_path / "rows.csv.gz"
    with gzip.open(src, "wt", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    out = tmp_path / "rows_sa.csv"
    subprocess.run([sys.executable, str(BENCH), "--models", str(models), "--rows", str(src), "--out", str(out)],
                   check=True, capture_output=True)
    before, after = read_rows(src), read_rows(out)
    f = np.array(sigma_scale("narrow"))
    for b, a in zip(before, after):
        assert {k: v for k, v in a.items() if k != "sigma_add_mm"} == b
        stat = f * np.array([b["sigma_tx_mm"], b["sigma_ty_mm"], b["sigma_tz_mm"], b["sigma_r_deg"]])
        assert a["sigma_add_mm"] == pytest.approx(sigma_add_mm(stat[:3], stat[3], radius), rel=1e-12)
    # the converged pose keeps its sigma; the uncertain one is widened sideways to cover its 2.8 mm
    np.testing.assert_allclose(row_sigmas(after[0]), row_sigmas(before[0]))
    assert row_sigmas(after[1])[1] > row_sigmas(before[1])[1]
    assert 2.0 * row_sigmas(after[1])[1] >= 2.8
