"""bench/bench_contour_spaces.py's opponent space: a white (specular) addition in linear light leaves
the opponent channels unchanged, so an edge field on them does not see a white rim; an analytic
image, not fast-rendered."""
import importlib.util
import sys
from pathlib import Path

import numpy as np

_bench = Path(__file__).parents[1] / "bench"
sys.path.insert(0, str(_bench))
_spec = importlib.util.spec_from_file_location("bench_contour_spaces", _bench / "bench_contour_spaces.py")
bcs = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bcs)


def test_a_white_addition_cancels_in_the_opponent_channels():
    rng = np.random.default_rng(3)
    lin = rng.uniform(0.0, 200.0, (50, 3))
    o0, o1 = bcs.opponent(lin), bcs.opponent(lin + 37.5)
    assert np.abs(o1 - o0).max() < 1e-9
    # a coloured addition does not cancel
    assert np.abs(bcs.opponent(lin + np.array([30.0, 0.0, 0.0])) - o0).max() > 10.0


def test_a_white_rim_moves_the_colour_edge_but_not_the_opponent_edge():
    from ycbvss.refine.contour_match import _minimum_along
    from ycbvss.refine.edge import edge_field, linear_to_srgb

    # a red disc (radius 40 px) on a grey ground, area-sampled 8 x 8; the outermost 1.5 px ring
    # brightened by a white addition as a glossy rim would be
    h = w = 128
    ss = 8
    yy, xx = (np.mgrid[0:h * ss, 0:w * ss] + 0.5) / ss - 0.5
    r = np.hypot(xx - 63.5, yy - 63.5)
    obj, ground = np.array([120.0, 20.0, 20.0]), np.array([60.0, 60.0, 60.0])
    lin = np.where((r < 40.0)[..., None], obj, ground)
    rim = ((r < 40.0) & (r > 38.5))[..., None]
    lin_rim = lin + 25.0 * rim
    def image(lin_hi):
        lo = lin_hi.reshape(h, ss, w, ss, 3).mean(axis=(1, 3))
        return np.clip(np.rint(linear_to_srgb(lo)), 0, 255).astype(np.uint8)
    ang = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    n = np.c_[np.cos(ang), np.sin(ang)]
    uv = 63.5 + 40.0 * n
    def edge_at(img, field):
        return _minimum_along(field(img), uv, n, 1.5, 0.25)
    col = lambda im: edge_field(im, 1.0, colour=True)
    opp = lambda im: bcs.opponent_field(im, 1.0)
    shift_col = np.mean(edge_at(image(lin_rim), col) - edge_at(image(lin), col))
    shift_opp = np.mean(edge_at(image(lin_rim), opp) - edge_at(image(lin), opp))
    print(f"white rim: colour edge moves {shift_col:+.3f} px, opponent edge {shift_opp:+.3f} px")
    assert abs(shift_col) > 0.1, shift_col          # the rim moves the colour edge
    assert abs(shift_opp) < 0.03, shift_opp         # and not the opponent one
