"""sRGB transfer functions (IEC 61966-2-1) as tables computed by colour-science.

colour-science takes about a second to import; the refiner needs only the sRGB decoding of 8-bit
values and the encoding of linear light, in every process that refines a scene (the status pass
lights each view's template). Both are read from ``srgb_tables.npz`` beside this module, written
by colour-science (``python -m ycbvss.refine.srgb`` rewrites it; tests/test_srgb.py checks the
tables against colour-science):

- ``decode_u8`` (256,): linear light of each 8-bit code, in [0, 1];
- ``encode`` (ENCODE_SIZE + 1,): encoded value at linear light k / ENCODE_SIZE, read by linear
  interpolation (at most 2e-5 off colour-science's value, 0.005 of an 8-bit step).

:func:`encode_u8` rounds that encoding to 8-bit codes through a per-cell threshold table derived
from ``encode`` (same codes as rounding :func:`encode`, ~20x faster than ``np.interp``).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

ENCODE_SIZE = 4096
_ENCODE_GRID = np.linspace(0.0, 1.0, ENCODE_SIZE + 1)      # linear light of the encode table's entries
TABLES = Path(__file__).with_name("srgb_tables.npz")
_TABLES: dict | None = None


def build_tables() -> dict[str, np.ndarray]:
    """The two tables, computed by colour-science."""
    import colour  # lazy: ~1 s to import; only to (re)build the tables

    return {"decode_u8": np.asarray(colour.cctf_decoding(np.arange(256) / 255.0, function="sRGB"), np.float64),
            "encode": np.asarray(colour.cctf_encoding(np.arange(ENCODE_SIZE + 1) / ENCODE_SIZE, function="sRGB"),
                                 np.float64)}


def tables() -> dict[str, np.ndarray]:
    """The tables from ``srgb_tables.npz`` (loaded once per process)."""
    global _TABLES
    if _TABLES is None:
        with np.load(TABLES) as z:
            _TABLES = {k: z[k] for k in z.files}
    return _TABLES


def encode(linear01: np.ndarray) -> np.ndarray:
    """Linear light (clipped to [0, 1]) -> sRGB-encoded value in [0, 1], float64: the encode
    table read by linear interpolation. The grid is uniform (k / ENCODE_SIZE, exact in float64),
    so the cell index is a floor, not a search; the arithmetic is ``np.interp``'s (slope x offset
    + value), so the values are bit-identical to it, ~10x faster."""
    x = np.clip(np.asarray(linear01, np.float64), 0.0, 1.0)
    slope, enc = _encode_slopes()
    with np.errstate(invalid="ignore"):         # NaN: any cell, stays NaN
        cell = np.clip((x * ENCODE_SIZE).astype(np.intp), 0, ENCODE_SIZE - 1)
    out = slope[cell] * (x - _ENCODE_GRID[cell]) + enc[cell]
    return np.where(x >= 1.0, enc[-1], out)


_SLOPES: np.ndarray | None = None


def _encode_slopes() -> tuple[np.ndarray, np.ndarray]:
    """(per-cell slope of the encode table (ENCODE_SIZE,), the table (ENCODE_SIZE + 1,))."""
    global _SLOPES
    enc = tables()["encode"]
    if _SLOPES is None:
        _SLOPES = np.diff(enc) / np.diff(_ENCODE_GRID)
    return _SLOPES, enc


# encode_u8's cells: linear light [0, 255] cut into U8_CELLS equal cells; the steepest part of the
# encoding (slope 12.92 near black) puts at most one code boundary into a cell of 255 / 8192
U8_CELLS = 8192
_U8_TABLE: tuple[np.ndarray, np.ndarray] | None = None


def _u8_table() -> tuple[np.ndarray, np.ndarray]:
    """Per cell: the code at its lower edge (uint8) and the linear light (in [0, 255]) of the one
    code boundary inside it, +inf when none. A boundary is where :func:`encode` x 255 crosses
    k + 0.5, found by inverting the piecewise-linear encode table."""
    global _U8_TABLE
    if _U8_TABLE is None:
        bounds = np.interp((np.arange(255) + 0.5) / 255.0, tables()["encode"], _ENCODE_GRID) * 255.0
        edges = np.arange(U8_CELLS + 1) * (255.0 / U8_CELLS)
        lo = np.searchsorted(bounds, edges[:-1], side="right")
        inside = np.searchsorted(bounds, edges[1:], side="left") - lo
        if inside.max() > 1:           # cannot happen for sRGB; a wrong table would break encode_u8
            raise ValueError(f"{TABLES}: more than one 8-bit code boundary in a cell of the encode table")
        thr = np.full(U8_CELLS, np.inf)
        thr[inside == 1] = bounds[lo[inside == 1]]
        _U8_TABLE = (lo.astype(np.uint8), thr)
    return _U8_TABLE


def encode_u8(linear255: np.ndarray) -> np.ndarray:
    """Linear light in [0, 255] (clipped) -> 8-bit sRGB code, uint8 of the same shape: the
    rounded :func:`encode` (codes differ only where the encoding is exactly k + 0.5)."""
    lo, thr = _u8_table()
    x = np.asarray(linear255)
    cell = np.clip((x * (U8_CELLS / 255.0)).astype(np.int32), 0, U8_CELLS - 1)
    return lo[cell] + (x >= thr[cell]).astype(np.uint8)


if __name__ == "__main__":
    import os

    tmp = TABLES.with_suffix(".npz.tmp")
    with open(tmp, "wb") as fh:           # written whole, then renamed over the old tables
        np.savez(fh, **build_tables())
    os.replace(tmp, TABLES)
    print(TABLES)
