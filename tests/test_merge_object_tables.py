"""bench/merge_object_tables.py: merging per-object tables by pose count equals the mean over the pooled poses."""
import csv
import importlib.util
from pathlib import Path

import numpy as np

_spec = importlib.util.spec_from_file_location("merge_object_tables", Path(__file__).parents[1] / "bench" / "merge_object_tables.py")
mot = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(mot)


def _table(path: Path, poses: dict[str, np.ndarray]) -> None:
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(("object",) + mot.COLS + ("poses",))
        for o, e in poses.items():
            w.writerow([o] + list(e.mean(0)) + [len(e)])
        w.writerow(["all (mean over objects)"] + [0.0] * len(mot.COLS) + [0])


def test_merge_is_the_mean_over_the_pooled_poses(tmp_path):
    rng = np.random.default_rng(2)
    a = {"002_master_chef_can": rng.gamma(2.0, 0.1, (37, 5)), "011_banana*": rng.gamma(2.0, 0.2, (12, 5))}
    b = {"002_master_chef_can": rng.gamma(2.0, 0.1, (5, 5)), "040_large_marker": rng.gamma(2.0, 0.1, (9, 5))}
    _table(tmp_path / "a.csv", a)
    _table(tmp_path / "b.csv", b)
    m = mot.merge([tmp_path / "a.csv", tmp_path / "b.csv"])
    assert sorted(m) == ["002_master_chef_can", "011_banana*", "040_large_marker"]
    pooled = np.concatenate([a["002_master_chef_can"], b["002_master_chef_can"]])
    assert m["002_master_chef_can"][1] == 42
    assert np.abs(m["002_master_chef_can"][0] - pooled.mean(0)).max() < 1e-12
    assert np.abs(m["011_banana*"][0] - a["011_banana*"].mean(0)).max() < 1e-12
