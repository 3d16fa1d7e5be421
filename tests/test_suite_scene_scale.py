"""bench/suite_scene_scale.py: one scale per clip is recovered from the poses' errors, and taking it out
leaves what is not scale."""
import importlib.util
import json
from pathlib import Path

import numpy as np

_spec = importlib.util.spec_from_file_location("suite_scene_scale", Path(__file__).parents[1] / "bench" / "suite_scene_scale.py")
sss = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(sss)


def test_scale_and_remainder_from_rows(tmp_path):
    rng = np.random.default_rng(3)
    sdir = tmp_path / "test" / "000007"
    sdir.mkdir(parents=True)
    t = rng.uniform([-200, -150, 900], [200, 150, 1500], size=(40, 3))          # GT translations, mm
    noise = rng.normal(0.0, 0.05, size=(40, 3))
    d = -0.0008 * t + noise                      # the scene 0.08 % too small, plus 0.05 mm of noise
    d[5] = [30.0, 0.0, 40.0]                     # one failed pose, left out of the fit
    gt = {str(i): [{"obj_id": 3, "cam_t_m2c": t[i].tolist(), "cam_R_m2c": np.eye(3).ravel().tolist()}] for i in range(40)}
    (sdir / "scene_gt.json").write_text(json.dumps(gt))
    rows = [{"clip": "long-7", "init": "paper", "seed": "0", "scene_id": "7", "im_id": str(i), "obj_id": "3",
             "dx_mm": d[i, 0], "dy_mm": d[i, 1], "dz_mm": d[i, 2]} for i in range(40)]
    (label, (n, s_pct, signed, mean_abs, rest)), = sss.clip_scale_rows(rows, tmp_path)
    assert label == "long-7 / paper / seed 0" and n == 40
    assert abs(s_pct - (-0.08)) < 0.005                  # recovered within 0.005 % despite the failed pose
    assert mean_abs > 0.9 and rest < mean_abs - 0.8      # ~1 mm of depth error, almost all of it scale
