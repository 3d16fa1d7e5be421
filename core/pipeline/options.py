"""Command-line options shared by several ``ycbvss`` commands: ``--split`` and ``--options`` (any
:class:`ycbvss.refine.RefineOptions` field set from a JSON object, given inline or as a file)."""
from __future__ import annotations

import json
from pathlib import Path

from ..errors import YcbvssError

SPLIT_HELP = "split folder name, e.g. test (default: the dataset's only split)"


def add_split_option(parser, help: str = SPLIT_HELP) -> None:
    """``--split``: a BOP split folder; None lets ``ycbvss.io.bop_dataset.resolve_split`` pick the
    dataset's only split."""
    parser.add_argument("--split", default=None, help=help)


OPTIONS_HELP = ("refiner options as a JSON object of RefineOptions fields, inline ('{\"axis_hold\": \"narrow,medium\"}') "
                "or as a .json file (@FILE or FILE.json); applied on top of the other flags")


def add_options_arg(parser) -> None:
    """Add ``--options JSON`` to an argparse (sub)parser."""
    parser.add_argument("--options", default=None, metavar="JSON", help=OPTIONS_HELP)


def read_options_arg(text: str | None) -> dict:
    """The validated RefineOptions keyword arguments of an ``--options`` value (``{}`` for None):
    a JSON object, ``@path`` or a path ending in ``.json``. Bad input raises :class:`YcbvssError`
    naming the file or the argument."""
    from ..refine.options import options_from_mapping

    if text is None:
        return {}
    where: Path | None = None
    src = text.strip()
    if src.startswith("@") or (src.endswith(".json") and not src.startswith("{")):
        where = Path(src[1:] if src.startswith("@") else src)
        if not where.is_file():
            raise YcbvssError("--options file not found", where)
        src = where.read_text()
    try:
        obj = json.loads(src)
    except json.JSONDecodeError as e:
        raise YcbvssError(f"--options is not valid JSON ({e.msg} at line {e.lineno} column {e.colno})", where) from None
    if not isinstance(obj, dict):
        raise YcbvssError(f"--options must be a JSON object of RefineOptions fields, got {type(obj).__name__}", where)
    try:
        return options_from_mapping(obj)
    except ValueError as e:
        raise YcbvssError(f"--options: {e}", where) from None
