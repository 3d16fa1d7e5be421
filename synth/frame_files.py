"""All-or-nothing output of one frame: every file goes to a temporary name first; ``commit`` renames
them all and then writes the frame's done marker (the marker is the last file, so a frame counts as
done only when all its files are). On any error nothing of the frame is left behind.
"""
from __future__ import annotations

import errno
import os
from pathlib import Path

import cv2
import numpy as np

from ..errors import YcbvssError
from ..io.atomic import new_temp_file, write_json_atomic

PNG_PARAMS = None


def _png_params():
    return [cv2.IMWRITE_PNG_COMPRESSION, 3]


class FrameFiles:
    """Collects a frame's files as temporaries, then renames them together."""

    def __init__(self, where: str):
        self.where = where
        self._pending: list[tuple[Path, Path]] = []
        self._committed: list[Path] = []

    def _tmp(self, path: Path) -> Path:
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            return new_temp_file(path, path.suffix)
        except OSError as e:
            raise self._error(e, path) from None

    def _error(self, e: OSError, path: Path) -> YcbvssError:
        msg = "disk full" if e.errno == errno.ENOSPC else (e.strerror or str(e))
        return YcbvssError(f"cannot write output ({msg})", path, self.where)

    def png(self, path, image: np.ndarray) -> None:
        """PNG (uint8/uint16; 3-channel input is RGB)."""
        path = Path(path)
        tmp = self._tmp(path)
        self._pending.append((tmp, path))
        im = image
        if im.ndim == 3:
            im = cv2.cvtColor(im, cv2.COLOR_RGB2BGR)
        try:
            ok = cv2.imwrite(str(tmp), im, _png_params())
        except cv2.error:
            ok = False
        if not ok:
            raise YcbvssError("cannot write PNG (disk full or not writable?)", path, self.where)

    def commit(self, marker_path, marker: dict) -> None:
        """fsync + rename all temporaries, then write the done marker atomically."""
        try:
            for tmp, final in self._pending:
                with open(tmp, "rb+") as f:
                    os.fsync(f.fileno())
            for tmp, final in self._pending:
                os.replace(tmp, final)
                self._committed.append(final)
            self._pending = []
            write_json_atomic(marker_path, marker)
        except OSError as e:
            self.abort()
            raise self._error(e, Path(marker_path)) from None
        except BaseException:
            self.abort()
            raise

    def abort(self) -> None:
        """Remove temporaries and any already renamed file of this frame."""
        for tmp, _ in self._pending:
            Path(tmp).unlink(missing_ok=True)
        for p in self._committed:
            Path(p).unlink(missing_ok=True)
        self._pending, self._committed = [], []


def clean_temporaries(folder: Path) -> int:
    """Delete ``.tmp-*`` leftovers of an interrupted run under ``folder``; returns how many."""
    n = 0
    folder = Path(folder)
    if not folder.exists():
        return 0
    for p in folder.rglob(".tmp-*"):
        try:
            p.unlink()
            n += 1
        except OSError:
            pass
    return n
