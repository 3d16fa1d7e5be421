"""Where and from what a result was made: the host and a digest of the images.

Blender Cycles renders a frame bit for bit the same on one host, but the suite's renders and the
YCBV-SS synthesis have not reproduced between sessions with unchanged code (the suite in sessions
69-71, the shared clips' YCBV-SS between sessions 62 and 72: session 62's refiner gives today's
figures on today's images). A likely cause is Cycles' CPU kernels, chosen per host CPU. The
records written here (the suite's scene markers, ``synth_report.json``, the suite runs'
``provenance.json``) let two results be told apart by their images and hosts instead of guessed at.
"""
from __future__ import annotations

import hashlib
import platform
from importlib import metadata
from pathlib import Path
from typing import Iterable

# CPU features that select Cycles' (and numpy's, OpenCV's) CPU kernels
ISA_FLAGS = ("sse4_1", "sse4_2", "avx", "avx2", "fma", "avx512f", "avx512bw", "avx512vl")


def _cpu_info(path: Path = Path("/proc/cpuinfo")) -> tuple[str, list[str]]:
    """(CPU model name, its ISA_FLAGS present) from ``path`` (Linux); (platform.processor(), [])
    where that file does not exist."""
    try:
        text = path.read_text()
    except OSError:
        return platform.processor() or "unknown", []
    model, flags = "unknown", set()
    for line in text.splitlines():
        key, _, value = line.partition(":")
        key = key.strip()
        if key == "model name" and model == "unknown":
            model = value.strip()
        elif key in ("flags", "Features") and not flags:
            flags = set(value.split())
    return model, [f for f in ISA_FLAGS if f in flags]


def _version(dist: str) -> str | None:
    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return None


def host_record() -> dict:
    """The host this process runs on: CPU model and ISA flags, OS, machine, Python, and the versions
    of the packages whose kernels shape rendered images and refined numbers (bpy, numpy, OpenCV)."""
    cpu, flags = _cpu_info()
    return {"cpu": cpu, "isa": flags, "system": platform.system(), "machine": platform.machine(),
            "python": platform.python_version(), "bpy": _version("bpy"), "numpy": _version("numpy"),
            "opencv": _version("opencv-python-headless") or _version("opencv-python")}


def files_sha256(paths: Iterable[str | Path]) -> str:
    """SHA-256 (hex, first 16 digits) over the files ``paths`` in the given order, each as its file
    name and its bytes: equal for the same files with the same content, different when any byte,
    name or the order differs."""
    h = hashlib.sha256()
    for p in paths:
        p = Path(p)
        h.update(p.name.encode() + b"\0")
        with open(p, "rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
        h.update(b"\0")
    return h.hexdigest()[:16]


def rgb_sha256(scene_dir: str | Path) -> str | None:
    """:func:`files_sha256` of a BOP scene folder's ``rgb/`` images in name order (None if it has none)."""
    files = sorted(p for p in (Path(scene_dir) / "rgb").glob("*") if p.suffix.lower() in (".png", ".jpg", ".jpeg"))
    return files_sha256(files) if files else None
