"""bench/bench_edge_pull.py's sample classes: what lies 1 px and 2-4 px outside a contour sample."""
import importlib.util
from pathlib import Path

import numpy as np

_spec = importlib.util.spec_from_file_location("bench_edge_pull", Path(__file__).parents[1] / "bench" / "bench_edge_pull.py")
bep = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bep)


def test_contour_samples_are_classed_by_the_neighbour_outside_them():
    inst = np.zeros((20, 30), np.int32)
    inst[5:15, 5:12] = 1                 # the object
    inst[5:15, 12:16] = 2                # a neighbour touching its right side
    inst[5:15, 0:2] = 3                  # another one 3-4 px left of its left side (a gap of 2 px)
    uv = np.array([[11.0, 10.0], [5.0, 10.0], [8.0, 5.0]])      # right, left, top edge pixels
    n = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, -1.0]])
    assert bep.sample_classes(inst, uv, n, 1).tolist() == [0, 1, 2]


def test_free_samples_near_a_t_junction_get_their_own_class():
    inst = np.zeros((20, 30), np.int32)
    inst[5:15, 5:12] = 1
    junction = np.zeros(inst.shape, bool)
    junction[5:8, 9:12] = True          # the object's pixels near a cut at its top right corner
    uv = np.array([[11.5, 6.0], [11.5, 12.0], [8.0, 4.5]])      # right edge near the cut, right edge far, top
    n = np.array([[1.0, 0.0], [1.0, 0.0], [0.0, -1.0]])
    assert bep.sample_classes(inst, uv, n, 1, junction).tolist() == [3, 2, 2]
    assert bep.sample_classes(inst, uv, n, 1).tolist() == [2, 2, 2]
