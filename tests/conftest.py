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
from pathlib import Path

import pytest

from pinid import RobotModel


def shared_data() -> Path:
    """The project's shared recordings: ``$PINID_SHARED_DATA``, else ``../shared/data`` beside the clone,
    else ``/work/shared/data`` (where a clone elsewhere on the project's machine finds them).  Tests that
    need them skip when none exists."""
    candidates = [
        os.environ.get("PINID_SHARED_DATA"),
        Path(__file__).resolve().parents[2] / "shared" / "data",
        "/work/shared/data",
    ]
    for c in candidates:
        if c and (Path(c) / "double_pendulum").is_dir():
            return Path(c)
    return Path(candidates[1])


@functools.cache
def load(name: str) -> RobotModel:
    """A RobotModel by name, cached."""
    return RobotModel.from_urdf(name)


@pytest.fixture
def exo() -> RobotModel:
    return load("exo_leg")


def run_cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    """Run ``pinid ARGS`` in a subprocess; return the completed process (text mode)."""
    return subprocess.run(
        [sys.executable, "-m", "pinid.cli", *args], capture_output=True, text=True, cwd=cwd, timeout=600
    )


def assert_clean_error(proc: subprocess.CompletedProcess, *fragments: str) -> None:
    """Exit status 2, one line on stderr containing every fragment, no traceback."""
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    err = proc.stderr.strip()
    assert "Traceback" not in err, err
    assert len(err.splitlines()) == 1, err
    for f in fragments:
        assert f in err, (f, err)


@pytest.fixture(scope="session")
def recording(tmp_path_factory) -> Path:
    """A short exo_leg recording (CSV, 3 s at 500 Hz: t, q_hip, q_knee, tau_hip, tau_knee; torques with signal)."""
    import numpy as np

    t = np.arange(1500) / 500.0
    q = np.c_[0.6 + 0.4 * np.sin(2 * t), -0.9 + 0.4 * np.sin(3 * t)]
    tau = np.c_[5 + np.sin(2 * t), 1 + np.cos(3 * t)]
    path = tmp_path_factory.mktemp("rec") / "r.csv"
    rows = ["t,q_hip,q_knee,tau_hip,tau_knee"] + [
        ",".join(f"{v:.9g}" for v in (a, *b, *c)) for a, b, c in zip(t, q, tau)
    ]
    path.write_text("\n".join(rows) + "\n")
    return path
