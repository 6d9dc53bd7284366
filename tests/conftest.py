"""Shared fixtures: models are loaded once per test session."""

from __future__ import annotations

import os

# One BLAS thread, before numpy loads: on a 2-core machine threaded OpenBLAS on tall matrices is
# 10-40x slower whenever anything else runs (measured in docs/identification.md).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import functools
import subprocess
import sys

import pytest

from pinid import RobotModel


@functools.lru_cache(maxsize=None)
def load(name: str) -> RobotModel:
    """A RobotModel by name, cached."""
    return RobotModel.from_urdf(name)


@pytest.fixture
def exo() -> RobotModel:
    return load("exo_leg")


def run_cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    """Run ``pinid ARGS`` in a subprocess; return the completed process (text mode)."""
    return subprocess.run([sys.executable, "-m", "pinid.cli", *args], capture_output=True, text=True, cwd=cwd,
                          timeout=600)


def assert_clean_error(proc: subprocess.CompletedProcess, *fragments: str) -> None:
    """Exit status 2, one line on stderr containing every fragment, no traceback."""
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    err = proc.stderr.strip()
    assert "Traceback" not in err, err
    assert len(err.splitlines()) == 1, err
    for f in fragments:
        assert f in err, (f, err)
