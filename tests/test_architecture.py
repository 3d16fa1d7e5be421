"""The layer contracts of ARCHITECTURE.md (pyproject ``[tool.importlinter]``), checked with import-linter.

import-linter (grimp) finds a package's modules below its folder, but here the installed package is
assembled from several top-level folders (pyproject ``package-dir``: ycbvss = core/, ycbvss.synth =
synth/, ...). So the test copies the sources into that layout in a temporary folder and runs
``lint-imports`` on the copy, in a subprocess that finds ``ycbvss`` there first. Budget: ~10 s.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

pytest.importorskip("importlinter")


def _assemble(dest: Path) -> Path:
    """Copy every package folder of pyproject's package-dir to its installed place under ``dest``."""
    cfg = tomllib.loads((REPO / "pyproject.toml").read_text())
    mapping = cfg["tool"]["setuptools"]["package-dir"]
    for name, folder in sorted(mapping.items(), key=lambda kv: kv[0].count(".")):
        target = dest.joinpath(*name.split("."))
        shutil.copytree(REPO / folder, target, dirs_exist_ok=True,
                        ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    return dest


def test_import_contracts(tmp_path):
    src = _assemble(tmp_path / "src")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(src), os.environ.get("PYTHONPATH", "")])}
    cmd = [sys.executable, "-c", "from importlinter.cli import lint_imports_command; lint_imports_command()",
           "--config", str(REPO / "pyproject.toml"), "--no-cache"]
    r = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert "Contracts: " in r.stdout and " broken" in r.stdout, r.stdout + r.stderr
    assert r.returncode == 0, r.stdout + r.stderr
    assert "0 broken" in r.stdout


def test_copy_is_what_lint_imports_reads(tmp_path):
    """The subprocess must resolve ycbvss to the assembled copy (not an editable install)."""
    src = _assemble(tmp_path / "src")
    env = {**os.environ, "PYTHONPATH": str(src)}
    r = subprocess.run([sys.executable, "-c", "import ycbvss.refine, ycbvss.eval; "
                        "print(ycbvss.__file__); print(ycbvss.refine.__file__); print(ycbvss.eval.__file__)"],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert all(line.startswith(str(src)) for line in r.stdout.split()), r.stdout
