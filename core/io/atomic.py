"""Atomic writes: write to a temporary file in the target folder, fsync, then rename.

A crash (even SIGKILL) leaves either the old file or the complete new one, never half a file.
Temporary names start with ``.tmp-`` so readers and resume logic can ignore them.
"""
from __future__ import annotations

import contextlib
import errno
import json
import os
import secrets
from pathlib import Path
from typing import Any, Iterator

import numpy as np

from ..errors import YcbvssError


def new_temp_file(path: Path, suffix: str) -> Path:
    """Create an empty ``.tmp-<stem>-<random><suffix>`` next to ``path`` and return its path.

    Created with ``O_EXCL`` and mode 0o666, so the kernel applies the process umask (the final
    file gets the usual rw-r--r--) without reading or changing the umask. OSError propagates."""
    path = Path(path)
    for _ in range(100):
        tmp = path.parent / f".tmp-{path.stem}-{secrets.token_hex(4)}{suffix}"
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return tmp
    raise FileExistsError(errno.EEXIST, "no free temporary name", str(path.parent))


@contextlib.contextmanager
def atomic_path(path: str | Path, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path next to ``path``; on success rename it onto ``path``.

    The temporary name keeps the extension (OpenCV/EXR writers pick the format from it).
    On any exception the temporary file is removed and ``path`` is untouched.
    """
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise YcbvssError(f"cannot create output folder: {e.strerror}", path.parent) from None
    sfx = suffix if suffix is not None else "".join(path.suffixes[-1:])
    try:
        tmp = new_temp_file(path, sfx)
    except OSError as e:
        raise YcbvssError(f"output not writable: {e.strerror}", path) from None
    try:
        yield tmp
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError as e:
        tmp.unlink(missing_ok=True)
        msg = "disk full" if e.errno == errno.ENOSPC else (e.strerror or str(e))
        raise YcbvssError(f"cannot write: {msg}", path) from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_bytes_atomic(path: str | Path, data: bytes) -> None:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_text_atomic(path: str | Path, text: str) -> None:
    write_bytes_atomic(path, text.encode("utf-8"))


def _json_default(o: Any):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.integer):
        return int(o)
    if isinstance(o, np.floating):
        return float(o)
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o)}")


def dumps_json(obj: Any, indent: int | None = 2) -> str:
    return json.dumps(obj, indent=indent, default=_json_default, sort_keys=False)


def write_json_atomic(path: str | Path, obj: Any, indent: int | None = 2) -> None:
    """Write JSON atomically (numpy arrays/scalars allowed)."""
    write_text_atomic(path, dumps_json(obj, indent) + "\n")


def read_json(path: str | Path, what: str = "") -> Any:
    """Read JSON; a missing, truncated or malformed file raises one clear YcbvssError."""
    path = Path(path)
    if not path.is_file():
        raise YcbvssError(f"missing {what or 'JSON file'}", path)
    try:
        with open(path, "r", encoding="utf-8") as f:
            return json.load(f)
    except json.JSONDecodeError as e:
        raise YcbvssError(f"malformed or truncated JSON (line {e.lineno} col {e.colno}: {e.msg})",
                          path) from None
    except UnicodeDecodeError:
        raise YcbvssError("not a UTF-8 text file", path) from None
