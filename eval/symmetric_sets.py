"""Named sets of objects scored with ADD-S (all others with ADD) for YCB-V.

- ``paper`` (default): Li et al.'s protocol, 024_bowl only (obj 13);
- ``bop``: BOP's ycbv symmetric objects (bop_toolkit ``dataset_params``: 1, 13, 14, 16, 18, 19, 20, 21);
- ``posecnn``: PoseCNN / PVN3D / DenseFusion's ADD-S set (13 bowl, 16 wood block, 19 large clamp,
  20 extra-large clamp, 21 foam brick);
- or explicit obj_ids (``--symmetric 13 16``), or ``none``.
"""
from __future__ import annotations

from ..errors import YcbvssError

PRESETS: dict[str, tuple[int, ...]] = {
    "paper": (13,),
    "bop": (1, 13, 14, 16, 18, 19, 20, 21),
    "posecnn": (13, 16, 19, 20, 21),
    "none": (),
}


def parse_symmetric(tokens) -> tuple[tuple[int, ...], str]:
    """``--symmetric`` values -> (obj_ids, label for table headers). ``tokens``: None/[] = paper."""
    if tokens is None:
        return PRESETS["paper"], "paper"
    toks = [t for tok in ([tokens] if isinstance(tokens, str) else tokens) for t in str(tok).split(",") if t]
    if not toks:
        return (), "none"
    if len(toks) == 1 and toks[0].lower() in PRESETS:
        return PRESETS[toks[0].lower()], toks[0].lower()
    try:
        ids = tuple(sorted({int(t) for t in toks}))
    except ValueError:
        raise YcbvssError(f"--symmetric: expected paper, bop, posecnn, none or obj_ids, got {' '.join(toks)!r}") from None
    for name, ps in PRESETS.items():
        if ps == ids:
            return ids, name
    return ids, "ids " + ",".join(str(i) for i in ids)


def header_label(label: str, ids) -> str:
    """'ADD-S for paper (13)' -- the text put in table captions/headers."""
    return f"ADD-S set: {label} ({', '.join(str(i) for i in ids) or 'none'})"
