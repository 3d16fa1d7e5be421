"""Progress bars (tqdm on stderr) with one switch to silence them (YCBVSS_NO_PROGRESS=1)."""
from __future__ import annotations

import os
from typing import Iterable

from tqdm.auto import tqdm


def progress(iterable: Iterable | None = None, desc: str = "", total: int | None = None,
             unit: str = "it", **kw):
    """A tqdm bar showing rate and ETA; disabled when YCBVSS_NO_PROGRESS is set."""
    disable = bool(os.environ.get("YCBVSS_NO_PROGRESS"))
    return tqdm(iterable, desc=desc, total=total, unit=unit, disable=disable, dynamic_ncols=True,
                mininterval=0.5, **kw)
