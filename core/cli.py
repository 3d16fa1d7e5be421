"""`ycbvss` command line. Each capability registers its own subcommands; errors are one line.

Subcommand modules keep heavy imports (bpy, moderngl, scipy) inside their handlers so that
``ycbvss --help`` stays fast.
"""
from __future__ import annotations

import argparse
import importlib
import sys
import warnings

from . import __version__
from .errors import YcbvssError

# (module, function): each function takes the argparse sub-parsers object and adds commands,
# setting ``func`` (handler taking the parsed args, returning an exit code) on each parser.
_REGISTRARS = [
    ("ycbvss.pipeline.cli", "register"),            # demo, validate
    ("ycbvss.pipeline.commands", "register"),       # convert, assets
    ("ycbvss.pipeline.synth_cli", "register"),      # synth, synth preview
    ("ycbvss.pipeline.refine_cli", "register"),     # refine
    ("ycbvss.pipeline.eval_cli", "register"),       # eval
    ("ycbvss.pipeline.benchmark_cli", "register"),  # benchmark make|run|score
    ("ycbvss.pipeline.export_cli", "register"),     # export, gt
]


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="ycbvss",
        description="ycbvss: YCB-Video/BOP data layer, YCBV-SS synthesis, bundle pose refinement "
                    "and pose evaluation. Run `ycbvss COMMAND --help` for the options of a command.")
    p.add_argument("--version", action="version", version=f"ycbvss {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for mod_name, fn in _REGISTRARS:
        try:
            mod = importlib.import_module(mod_name)
        except ModuleNotFoundError as e:
            if e.name == mod_name:
                continue
            raise
        getattr(mod, fn)(sub)
    return p


def _warning_line(message, category, filename, lineno, file=None, line=None):
    print(f"ycbvss: warning: {message}", file=sys.stderr if file is None else file)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    warnings.showwarning = _warning_line
    try:
        return int(args.func(args) or 0)
    except YcbvssError as e:
        print(f"ycbvss {args.command}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("ycbvss: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
