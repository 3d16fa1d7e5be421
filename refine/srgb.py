"""sRGB transfer functions (IEC 61966-2-1) as tables computed by colour-science.

colour-science takes about a second to import; the refiner needs only the sRGB decoding of 8-bit
values and the encoding of linear light, in every process that refines a scene (the status pass
lights each view's template). Both are read from ``srgb_tables.npz`` beside this module, written
by colour-science (``python -m ycbvss.refine.srgb`` rewrites it; tests/test_srgb.py checks the
tables against colour-science):

- ``decode_u8`` (256,): linear light of each 8-bit code, in [0, 1];
- ``encode`` (ENCODE_SIZE + 1,): encoded value at linear light k / ENCODE_SIZE, read by linear
  interpolation (at most 2e-5 off colour-science's value, 0.005 of an 8-bit step).
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
    """Linear light (clipped to [0, 1]) -> sRGB-encoded value in [0, 1], float64."""
    x = np.clip(np.asarray(linear01, np.float64), 0.0, 1.0)
    return np.interp(x, _ENCODE_GRID, tables()["encode"])


if __name__ == "__main__":
    import os

    tmp = TABLES.with_suffix(".npz.tmp")
    with open(tmp, "wb") as fh:           # written whole, then renamed over the old tables
        np.savez(fh, **build_tables())
    os.replace(tmp, TABLES)
    print(TABLES)
