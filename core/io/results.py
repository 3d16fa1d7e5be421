"""BOP19 results CSV: ``scene_id,im_id,obj_id,score,R,t,time``.

R is 9 numbers row-major separated by spaces, t is 3 numbers in mm, time in seconds (-1 when
unknown; BOP requires the same time for all estimates of one image).
"""
from __future__ import annotations

import csv
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import numpy as np

from ..errors import YcbvssError
from ..geometry.se3 import make_T
from ..geometry.so3 import orthonormality_error
from .atomic import write_text_atomic

HEADER = ["scene_id", "im_id", "obj_id", "score", "R", "t", "time"]


@dataclass
class Estimate:
    """One pose estimate of a BOP19 results file. ``T_m2c``: 4x4, translation in mm."""

    scene_id: int
    im_id: int
    obj_id: int
    score: float
    T_m2c: np.ndarray
    time_s: float = -1.0


def _floats(text: str, n: int, path: Path, line: int, what: str) -> np.ndarray:
    try:
        vals = np.array([float(x) for x in text.replace(",", " ").split()], dtype=np.float64)
    except ValueError:
        raise YcbvssError(f"line {line}: {what} is not numeric: {text!r}", path) from None
    if vals.size != n:
        raise YcbvssError(f"line {line}: {what} needs {n} numbers, got {vals.size}", path)
    return vals


def read_bop19_csv(path: str | Path, known_obj_ids: Iterable[int] | None = None,
                   rot_tol: float = 1e-4) -> list[Estimate]:
    """Read and validate a BOP19 results CSV.

    Raises one :class:`YcbvssError` naming the file, line, scene/frame/object for: a missing or
    malformed file, a wrong header, non-numeric fields, NaN/inf, R not orthonormal
    (|R^T R - I| > rot_tol), an object behind the camera (t_z <= 0), an unknown obj_id.
    """
    path = Path(path)
    if not path.is_file():
        raise YcbvssError("missing results CSV", path)
    known = None if known_obj_ids is None else set(int(i) for i in known_obj_ids)
    text = path.read_text(encoding="utf-8", errors="replace")
    reader = csv.reader(io.StringIO(text))
    try:
        header = next(reader)
    except StopIteration:
        raise YcbvssError("empty results CSV (no header)", path) from None
    header = [h.strip() for h in header]
    if header[:6] != HEADER[:6]:
        raise YcbvssError(f"bad header {','.join(header)!r}; expected {','.join(HEADER)}", path)
    out: list[Estimate] = []
    for line_no, row in enumerate(reader, start=2):
        if not row or all(not c.strip() for c in row):
            continue
        if len(row) < 6:
            raise YcbvssError(f"line {line_no}: truncated row ({len(row)} of 7 fields)", path)
        try:
            sid, iid, oid = int(row[0]), int(row[1]), int(row[2])
            score = float(row[3])
            t_s = float(row[6]) if len(row) > 6 and row[6].strip() else -1.0
        except ValueError:
            raise YcbvssError(f"line {line_no}: scene_id/im_id/obj_id/score/time not numeric", path) from None
        loc = f"line {line_no} (scene {sid} frame {iid} object {oid})"
        R = _floats(row[4], 9, path, line_no, "R").reshape(3, 3)
        t = _floats(row[5], 3, path, line_no, "t")
        if not (np.all(np.isfinite(R)) and np.all(np.isfinite(t)) and np.isfinite(score)):
            raise YcbvssError(f"{loc}: NaN/inf in pose or score", path)
        err = float(orthonormality_error(R))
        if err > rot_tol or np.linalg.det(R) < 0:
            raise YcbvssError(f"{loc}: R is not a rotation (|R^T R - I| = {err:.2e})", path)
        if t[2] <= 0:
            raise YcbvssError(f"{loc}: object behind the camera (t_z = {t[2]:.1f} mm)", path)
        if known is not None and oid not in known:
            raise YcbvssError(f"{loc}: unknown obj_id {oid} (models have {sorted(known)})", path)
        out.append(Estimate(sid, iid, oid, score, make_T(R, t), t_s))
    return out


def format_bop19_csv(estimates: Iterable[Estimate]) -> str:
    lines = [",".join(HEADER)]
    for e in estimates:
        R = " ".join(f"{v:.9g}" for v in np.asarray(e.T_m2c)[:3, :3].ravel())
        t = " ".join(f"{v:.6f}" for v in np.asarray(e.T_m2c)[:3, 3])
        lines.append(f"{e.scene_id},{e.im_id},{e.obj_id},{e.score:.6g},{R},{t},{e.time_s:.6g}")
    return "\n".join(lines) + "\n"


def write_bop19_csv(path: str | Path, estimates: Iterable[Estimate]) -> None:
    """Write a BOP19 results CSV atomically (R with 9 significant digits, t in mm to 1e-6)."""
    write_text_atomic(path, format_bop19_csv(estimates))
