"""refine.srgb: the stored sRGB tables are colour-science's values; no colour-science import at refine time."""
from __future__ import annotations

import subprocess
import sys

import numpy as np


def test_tables_match_colour_science():
    import colour

    from ycbvss.refine.edge import linear_to_srgb, srgb_to_linear
    from ycbvss.refine.srgb import ENCODE_SIZE, build_tables, tables

    stored, fresh = tables(), build_tables()
    assert set(stored) == set(fresh) and len(stored["encode"]) == ENCODE_SIZE + 1
    for k in fresh:
        assert np.abs(stored[k] - fresh[k]).max() < 1e-12, k
    codes = np.arange(256, dtype=np.uint8)
    dec = colour.cctf_decoding(codes / 255.0, function="sRGB") * 255.0
    assert np.abs(srgb_to_linear(codes) - dec).max() < 1e-4            # float32 table; measured 7.5e-6
    x = np.concatenate([np.linspace(0.0, 255.0, 200001), [0.0031308 * 255.0, 1e-6, 254.9999]])
    enc = colour.cctf_encoding(np.clip(x / 255.0, 0.0, 1.0), function="sRGB") * 255.0
    assert np.abs(linear_to_srgb(x) - enc).max() < 0.01                # interpolated; measured 0.0041 (of 255)
    assert np.abs(linear_to_srgb(srgb_to_linear(codes)) - codes).max() < 0.01


def test_lit_template_does_not_import_colour_science():
    code = ("import sys, numpy as np\n"
            "from ycbvss.refine.shading import lit_template\n"
            "rng = np.random.default_rng(0)\n"
            "img = rng.integers(0, 255, (40, 40, 3), dtype=np.uint8)\n"
            "n = np.zeros((40, 40, 3)); n[..., 2] = -1.0\n"
            "inst = np.ones((40, 40), np.int32)\n"
            "lit_template(img, n, inst, img)\n"
            "print('colour' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False", out.stdout + out.stderr


def test_encode_u8_equals_rounded_encode():
    """encode_u8 (per-cell threshold table) gives the codes of rint(encode x 255) everywhere except
    exactly on a code boundary (a tie that np.rint breaks to even)."""
    from ycbvss.refine.edge import linear_to_srgb
    from ycbvss.refine.srgb import _u8_table, encode_u8

    rng = np.random.default_rng(3)
    x = np.concatenate([rng.uniform(-5.0, 260.0, 400000), np.linspace(0.0, 255.0, 100001), [0.0, 255.0]])
    ref = np.clip(np.rint(linear_to_srgb(x)), 0, 255).astype(np.uint8)
    got = encode_u8(x)
    assert got.dtype == np.uint8 and got.shape == x.shape
    assert int((got != ref).sum()) == 0
    bounds = np.sort(_u8_table()[1][np.isfinite(_u8_table()[1])])
    assert len(bounds) == 255                                          # one boundary per code step
    below, above = np.nextafter(bounds, -np.inf), np.nextafter(bounds, np.inf)
    assert np.array_equal(encode_u8(above) - encode_u8(below), np.ones(255, np.uint8))
    f32 = rng.uniform(0.0, 255.0, (300, 400, 3)).astype(np.float32)      # images come as float32 too
    ref32 = np.clip(np.rint(linear_to_srgb(f32)), 0, 255).astype(np.uint8)
    assert (encode_u8(f32) != ref32).mean() < 1e-5


def test_encode_is_np_interp_of_the_table():
    """srgb.encode reads the table by a floor index, not a search: bit-identical to np.interp."""
    from ycbvss.refine.srgb import _ENCODE_GRID, encode, tables

    x = np.concatenate([np.random.default_rng(5).uniform(-0.1, 1.1, 500000), _ENCODE_GRID, [0.0, 1.0, -0.0]])
    ref = np.interp(np.clip(x, 0.0, 1.0), _ENCODE_GRID, tables()["encode"])
    assert np.array_equal(encode(x), ref)
    assert np.isnan(encode(np.array([np.nan, 0.5]))[0])
    assert encode(np.float32(0.5)).shape == () and encode(np.ones((2, 3, 3))).shape == (2, 3, 3)
