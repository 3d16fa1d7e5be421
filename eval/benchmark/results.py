"""Tracker results: one CSV file per subsequence, so that any tracker (a C++ one too) can be scored.

``DIR/NNNNN.csv`` (NNNNN = the subsequence ``id``, 5 digits), header line then one row per tracked
frame and object::

    im_id,obj_id,R,t,time
    1234,5,r11 r12 r13 r21 r22 r23 r31 r32 r33,tx ty tz,0.031

``R`` row-major, ``t`` in mm, object-to-camera in the frame's camera (BOP convention, as the
BOP19 result format); ``time`` seconds spent on that frame (all objects; optional, -1 = unknown).
Rows for the init frame ``frames[0]`` are ignored. A tracked (frame, object) without a row, or a
subsequence without a file, counts as a failure (infinite error). ``DIR/run.json`` (written by
``ycbvss benchmark run``) records the tracker and the config's sha256.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from ...errors import YcbvssError
from ...io.atomic import read_json, write_text_atomic

HEADER = "im_id,obj_id,R,t,time"


def result_path(out_dir: str | Path, sub_id: int) -> Path:
    return Path(out_dir) / f"{int(sub_id):05d}.csv"


def format_results(rows: list[tuple[int, int, np.ndarray, float]]) -> str:
    """rows: (im_id, obj_id, T_m2c 4x4 mm, time_s)."""
    out = [HEADER]
    for im_id, obj_id, T, dt in rows:
        T = np.asarray(T, dtype=np.float64)
        R = " ".join(f"{x:.17g}" for x in T[:3, :3].reshape(9))
        t = " ".join(f"{x:.17g}" for x in T[:3, 3])
        out.append(f"{int(im_id)},{int(obj_id)},{R},{t},{dt:.6g}")
    return "\n".join(out) + "\n"


def write_results(out_dir: str | Path, sub_id: int, rows) -> Path:
    p = result_path(out_dir, sub_id)
    write_text_atomic(p, format_results(rows))
    return p


def read_results(path: str | Path) -> dict[tuple[int, int], tuple[np.ndarray, np.ndarray, float]]:
    """One results file -> {(im_id, obj_id): (R 3x3, t (3,) mm, time_s)}. Errors name file and line;
    a repeated (im_id, obj_id) is an error."""
    path = Path(path)
    out = {}
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as e:
        raise YcbvssError(f"cannot read results: {e.strerror}", path) from None
    lines = text.splitlines()
    if not lines or lines[0].replace(" ", "").lower() != HEADER.lower():
        raise YcbvssError(f"first line must be the header '{HEADER}'", path)
    for ln, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        parts = line.split(",")
        if len(parts) not in (4, 5):
            raise YcbvssError(f"line {ln}: expected 5 fields ({HEADER}), got {len(parts)}", path)
        try:
            im_id, obj_id = int(parts[0]), int(parts[1])
            R = np.array([float(x) for x in parts[2].split()], dtype=np.float64)
            t = np.array([float(x) for x in parts[3].split()], dtype=np.float64)
            dt = float(parts[4]) if len(parts) == 5 and parts[4].strip() else -1.0
        except ValueError:
            raise YcbvssError(f"line {ln}: not numbers", path) from None
        wh = f"frame {im_id} object {obj_id}"
        if R.size != 9 or t.size != 3:
            raise YcbvssError(f"line {ln}: R needs 9 numbers and t 3, got {R.size} and {t.size}", path, wh)
        if (im_id, obj_id) in out:
            raise YcbvssError(f"line {ln}: second row for the same frame and object", path, wh)
        out[(im_id, obj_id)] = (R.reshape(3, 3), t, dt)
    return out


def config_sha256(cfg: dict) -> str:
    return hashlib.sha256(json.dumps(cfg, sort_keys=True).encode()).hexdigest()


def read_result_dir(out_dir: str | Path, cfg: dict) -> tuple[dict[int, dict], dict]:
    """All result files of a run directory for ``cfg``'s subsequences: ({sub_id: rows}, info) with
    info = {"name", "n_files", "n_missing_files", "run": run.json or {}}. A run.json whose config
    hash differs from ``cfg`` is an error (results of another configuration)."""
    d = Path(out_dir)
    if not d.is_dir():
        raise YcbvssError("results folder not found", d)
    run = {}
    if (d / "run.json").is_file():
        run = read_json(d / "run.json", "benchmark run info")
        h = run.get("config_sha256")
        if h and h != config_sha256(cfg):
            raise YcbvssError("results were made for another benchmark config (config_sha256 differs)", d / "run.json")
    res = {}
    missing = 0
    for s in cfg["subsequences"]:
        p = result_path(d, s["id"])
        if p.is_file():
            res[int(s["id"])] = read_results(p)
        else:
            missing += 1
    name = str(run.get("tracker_label") or run.get("tracker") or d.name)
    return res, {"name": name, "n_files": len(res), "n_missing_files": missing, "run": run}
