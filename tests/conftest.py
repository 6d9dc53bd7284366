"""Shared fixtures: models are loaded once per test session."""

from __future__ import annotations

import os

# One BLAS thread, before numpy loads: on a 2-core machine threaded OpenBLAS on tall matrices is
# 10-40x slower whenever anything else runs (measured in docs/identification.md).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import functools
import io
import subprocess
import sys
from pathlib import Path

import pytest

from pinid import RobotModel

# The tests mirror the package (tests/model/, tests/identification/, …; tests/contracts/, tests/architecture/,
# tests/docs/ across it) and import shared twins from each other by module name (``from test_identification
# import twin``): every test folder is on sys.path, whichever file pytest runs.  Test file names stay unique.
_TESTS = Path(__file__).resolve().parent
for _folder in sorted(_TESTS.iterdir()):
    if _folder.is_dir() and _folder.name != "benchmarks" and any(_folder.glob("test_*.py")):
        if str(_folder) not in sys.path:
            sys.path.append(str(_folder))


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


@pytest.fixture
def close_figures():
    """Closes every matplotlib figure after the test (``pytestmark = pytest.mark.usefixtures(...)``)."""
    yield
    import matplotlib.pyplot as plt

    plt.close("all")


@pytest.fixture(scope="session")
def leg_twins():
    """``(truth, training, validation)``: the exo leg with friction, an 8 s training and a 4 s held-out
    recording of it at 100 Hz (noise-free twins), for the result objects' tests."""
    from test_identification import truth_model, twin

    truth = truth_model("exo_leg")
    return truth, twin(truth, seconds=8, rate=100, seed=1), twin(truth, seconds=4, rate=100, seed=2)


@pytest.fixture(scope="session")
def leg_identification(leg_twins):
    """:func:`pinid.identify` with ols and sdp on :func:`leg_twins` (validated on its held-out recording)."""
    from pinid import Study, identify

    truth, train, valid = leg_twins
    return identify(Study(truth, train, validate=valid), methods=["ols", "sdp"])


@pytest.fixture(scope="module")
def floating_exo() -> RobotModel:
    """exo_lower_body on a free-flyer root joint, loaded once per test module."""
    return RobotModel.from_urdf("exo_lower_body", base="floating")


def floating_excitation(model, seed: int = 0, harmonics: int = 4, scale: float = 0.08):
    """A seeded Fourier excitation of every joint of ``model`` about the middle of its range (0.2 Hz base
    frequency, ``harmonics`` terms, amplitudes up to ``scale`` of each joint's span)."""
    import numpy as np

    from pinid.excitation.trajectory import FourierTrajectory

    rng = np.random.default_rng(seed)
    span = (model.upper - model.lower)[:, None]
    a, b = (rng.uniform(-1, 1, (model.nv, harmonics)) * scale * span for _ in range(2))
    return FourierTrajectory(model.joint_names, 2 * np.pi * 0.2, 0.5 * (model.lower + model.upper), a, b)


class _Captured(io.StringIO):
    """A captured stdout/stderr of an in-process run that reports the real file descriptor, so
    code that captures what C++ prints on fd 2 (urdfdom, pinid.model.robot) works as in a process."""

    def __init__(self, fd: int) -> None:
        super().__init__()
        self._fd = fd

    def fileno(self) -> int:
        return self._fd


def run_cli(*args: str, cwd=None, figures: bool = False) -> subprocess.CompletedProcess:
    """Run ``pinid ARGS`` in this process (``pinid.cli.main``, about 2 s cheaper than a subprocess that
    loads numpy, scipy, Pinocchio and matplotlib again); return a completed process (text mode) with
    the exit status, stdout and stderr.  ``pinid simulate`` gets ``--no-figures`` unless ``figures``
    (its PNG costs about a second and few tests look at it).  :func:`run_cli_subprocess` runs a real
    process."""
    import contextlib
    import signal

    from pinid.cli.main import main
    from pinid.io import OVERWRITE

    out, err = _Captured(1), _Captured(2)
    here, overwrite, sigterm = os.getcwd(), OVERWRITE.get(), signal.getsignal(signal.SIGTERM)
    try:
        if cwd is not None:
            os.chdir(cwd)
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                argv = [str(a) for a in args]
                if argv[:1] == ["simulate"] and not figures and "--no-figures" not in argv:
                    argv.append("--no-figures")
                status = main(argv)
            except SystemExit as exc:  # argparse: --help, --version, usage errors
                status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
                if isinstance(exc.code, str):
                    print(exc.code, file=sys.stderr)
    finally:
        os.chdir(here)
        OVERWRITE.set(overwrite)
        signal.signal(signal.SIGTERM, sigterm)
    return subprocess.CompletedProcess(["pinid", *args], status, out.getvalue(), err.getvalue())


def run_cli_subprocess(*args: str, cwd=None) -> subprocess.CompletedProcess:
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


def leg_csv(path: Path, samples: int, rate: float) -> Path:
    """Write a smooth exo_leg recording to ``path`` (CSV: t, q_hip, q_knee, tau_hip, tau_knee; ``samples`` at
    ``rate`` [Hz], torques with signal) and return it."""
    import numpy as np

    t = np.arange(samples) / rate
    q = np.c_[0.6 + 0.4 * np.sin(2 * t), -0.9 + 0.4 * np.sin(3 * t)]
    tau = np.c_[5 + np.sin(2 * t), 1 + np.cos(3 * t)]
    rows = ["t,q_hip,q_knee,tau_hip,tau_knee"] + [
        ",".join(f"{v:.9g}" for v in (a, *b, *c)) for a, b, c in zip(t, q, tau)
    ]
    path.write_text("\n".join(rows) + "\n")
    return path


@pytest.fixture(scope="session")
def recording(tmp_path_factory) -> Path:
    """A short exo_leg recording (:func:`leg_csv`, 3 s at 500 Hz)."""
    return leg_csv(tmp_path_factory.mktemp("rec") / "r.csv", 1500, 500.0)


@pytest.fixture(scope="session")
def good_csv(tmp_path_factory) -> Path:
    """A short, valid recording of exo_leg (:func:`leg_csv`, 2 s at 1 kHz); the CLI's bad-input tests change
    one thing in it."""
    return leg_csv(tmp_path_factory.mktemp("good") / "good.csv", 2000, 1000.0)


@pytest.fixture(scope="module")
def rec(tmp_path_factory) -> Path:
    """A 2 s exo_leg recording in the dataset format, in a folder of its own (``run.csv``, beside it
    ``run_torque.csv`` with the torques as k_hip, k_knee for mapping specs to point at)."""
    import numpy as np

    folder = tmp_path_factory.mktemp("rec") / "data"
    folder.mkdir()
    t = np.arange(2000) / 1000.0
    q = np.c_[0.6 + 0.4 * np.sin(2 * t), -0.9 + 0.4 * np.sin(3 * t)]
    tau = np.c_[5 + np.sin(2 * t), 1 + np.cos(3 * t)]
    rows = ["t,q_hip,q_knee,tau_hip,tau_knee"] + [
        ",".join(f"{v:.9g}" for v in (a, *b, *c)) for a, b, c in zip(t, q, tau)
    ]
    (folder / "run.csv").write_text("\n".join(rows) + "\n")
    (folder / "run_torque.csv").write_text("\n".join(["k_hip,k_knee"] + [f"{a:.9g},{b:.9g}" for a, b in tau]) + "\n")
    return folder / "run.csv"


def trajectory_file(path: Path, joints: list[str]) -> Path:
    """A two-joint Fourier trajectory file at ``path`` for ``joints`` (in that order): q0 = [-0.9, 0.6] and one
    0.3 rad harmonic, both in the order of ``joints``; the second joint does not move."""
    import json

    path.write_text(
        json.dumps(
            {
                "joints": joints,
                "base_frequency": 0.5,
                "harmonics": 1,
                "q0": [-0.9, 0.6],
                "a": [[0.3], [0.0]],
                "b": [[0.0], [0.0]],
            }
        )
    )
    return path


@pytest.fixture(scope="module")
def leg() -> RobotModel:
    """exo_leg, loaded once per test module."""
    return load("exo_leg")


@pytest.fixture(scope="module")
def model_json(tmp_path_factory) -> dict:
    """An identified exo_leg model (its standard parameters) as saved to JSON and read back as a dict."""
    import json

    from pinid import IdentifiedModel, standard_parameters

    leg = load("exo_leg")
    path = tmp_path_factory.mktemp("model") / "model_sdp.json"
    IdentifiedModel(leg, None, standard_parameters(leg)).save(path)
    return json.loads(path.read_text())


def tampered_json(tmp_path: Path, d: dict, change) -> Path:
    """A copy of the JSON dict ``d`` with ``change(copy)`` applied, written to ``tmp_path / "model.json"``."""
    import json

    d = json.loads(json.dumps(d))
    change(d)
    path = tmp_path / "model.json"
    path.write_text(json.dumps(d))
    return path


def knee_mass(value):
    """A change for :func:`tampered_json`: the knee mass of a saved model set to ``value``."""

    def change(d):
        d["standard_parameters"]["knee.m"] = value

    return change
