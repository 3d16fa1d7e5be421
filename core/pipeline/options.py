"""Command-line options shared by several ``ycbvss`` commands."""
from __future__ import annotations

SPLIT_HELP = "split folder name, e.g. test (default: the dataset's only split)"


def add_split_option(parser, help: str = SPLIT_HELP) -> None:
    """``--split``: a BOP split folder; None lets ``ycbvss.io.bop_dataset.resolve_split`` pick the
    dataset's only split."""
    parser.add_argument("--split", default=None, help=help)
