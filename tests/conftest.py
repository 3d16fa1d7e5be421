"""Shared fixtures. Tests that need ../shared/data skip when it is absent, except under CI=true."""
from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]


def shared_data_dir() -> Path:
    env = os.environ.get("YCBVSS_SHARED_DATA")
    return Path(env) if env else (REPO.parent / "shared" / "data")


def require_shared(sub: str = "") -> Path:
    """Path to ../shared/data/<sub>; skip if missing (fail under CI=true)."""
    p = shared_data_dir() / sub
    if not p.exists():
        msg = f"shared sample data not found at {p}"
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(msg + " (CI=true: the shared data must be present)")
        pytest.skip(msg)
    return p


@pytest.fixture(scope="session")
def shared_data() -> Path:
    return require_shared()


@pytest.fixture(scope="session")
def ycbv_root() -> Path:
    return require_shared("ycbv")


@pytest.fixture(scope="session")
def bop_models_root() -> Path:
    return require_shared("bop_ycbv_models")


@pytest.fixture(autouse=True)
def _quiet_progress(monkeypatch):
    monkeypatch.setenv("YCBVSS_NO_PROGRESS", "1")


def _fd_gradient(pb, term, h: float):
    """Central-difference gradient of ``term.cost`` over the free parameters of the bundle problem
    ``pb`` (step ``h`` in its se(3) increments); the state is restored after each probe."""
    import numpy as np

    g = np.zeros(pb.n_params)
    st = pb.state()
    for p in range(pb.n_params):
        d = np.zeros(pb.n_params)
        d[p] = h
        pb.apply_step(d)
        cp = term.cost(pb)
        pb.set_state(st)
        pb.apply_step(-d)
        cm = term.cost(pb)
        pb.set_state(st)
        g[p] = (cp - cm) / (2 * h)
    return g


@pytest.fixture
def fd_gradient():
    """:func:`_fd_gradient` (tests import no helpers from each other: --import-mode=importlib)."""
    return _fd_gradient
