"""The pinid command's frame (pinid/cli/main.py), across its commands: bad arguments, existing outputs, file
options that name devices or FIFOs, Ctrl-C, a closed pipe and a bug each give one line and the documented
exit status, no traceback, nothing written."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import assert_clean_error, run_cli

SLOW = pytest.mark.slow


def _no_files(folder: Path) -> None:
    left = [p.name for p in folder.rglob("*") if p.is_file()]
    assert not left, left


@pytest.mark.parametrize(
    "name, command",
    [
        ("run.csv", ["simulate", "--excitation", "zha2019-1", "--urdf", "apal_leg", "--seconds", "1", "-o", "{out}"]),
        ("info.json", ["info", "--urdf", "exo_leg", "--json", "{out}"]),
        ("tracking.json", ["track", "--seconds", "1", "--after", "0", "-o", "{folder}"]),
    ],
)
def test_existing_output_is_not_replaced(tmp_path, name, command):
    out = tmp_path / name
    out.write_text("precious")
    argv = [a.format(out=out, folder=tmp_path) for a in command]
    assert_clean_error(run_cli(*argv), "already exists")
    assert out.read_text() == "precious"


@pytest.mark.parametrize(
    "args, fragment",
    [
        (["simulate", "--excitation", "zha2019-1", "--urdf", "apal_leg", "--seconds", "-1"], "duration"),
        (["simulate", "--excitation", "nowhere.json", "--seconds", "1"], "nowhere.json"),
        (["simulate", "--excitation", "seed000-9", "--urdf", "apal_leg", "--seconds", "1"], "seed000-9"),
        (["track", "--reference", "nowhere.json", "--seconds", "1", "--after", "0"], "nowhere.json"),
        (["identify", "--urdf", "exo_leg", "--data", "nowhere.csv"], "nowhere.csv"),
        (["identify", "--urdf", "exo_leg", "--data", "x.csv", "--methods", "magic"], "magic"),
        (["info", "--urdf", "exo_leg", "--joints", "hip,ankle"], "ankle"),
    ],
)
def test_bad_arguments(tmp_path, args, fragment):
    proc = run_cli(*args, "-o", str(tmp_path / "o.csv")) if args[0] == "simulate" else run_cli(*args)
    assert_clean_error(proc, fragment)
    assert not (tmp_path / "o.csv").exists()


@pytest.mark.slow  # a real process: starts, simulates, is interrupted (7 s of CPU)
def test_interrupted_run_leaves_nothing(tmp_path):
    """Ctrl-C in the middle of a long simulation: status 2, one line, no file."""
    out = tmp_path / "long.csv"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "pinid.cli",
            "simulate",
            "--excitation",
            "zha2019-1",
            "--urdf",
            "apal_leg",
            "--seconds",
            "600",
            "-o",
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # a test runner started in the background inherits SIGINT ignored, and Python
        # then installs no KeyboardInterrupt handler: give the child the default back
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        # progress lines on: the first one is the marker that the simulation runs (a fixed sleep raced the
        # imports under load, and a progress line printed before the signal then broke "one line")
        env={**os.environ, "PINID_PROGRESS": "1", "PYTHONUNBUFFERED": "1"},
    )
    first = proc.stderr.readline()
    assert first.startswith("pinid: simulate"), first
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2, err
    *progress, last = err.strip().splitlines()
    assert "Traceback" not in err and all(line.startswith("pinid: simulate") for line in progress), err
    assert last.startswith("pinid simulate: interrupted"), err
    _no_files(tmp_path)


def test_a_bug_is_one_line_with_status_1_and_debug_shows_it(monkeypatch, capsys):
    """Not bad input but a bug: still no traceback by default (status 1), the traceback with PINID_DEBUG=1."""
    import pinid.cli.info as info
    from pinid.cli.main import main

    def broken(args):
        raise ValueError("something\nwent wrong")

    monkeypatch.setattr(info, "run", broken)
    monkeypatch.delenv("PINID_DEBUG", raising=False)
    assert main(["info", "--urdf", "exo_leg"]) == 1
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "internal error: ValueError: something went wrong" in err
    monkeypatch.setenv("PINID_DEBUG", "1")
    with pytest.raises(ValueError):
        main(["info", "--urdf", "exo_leg"])


def test_closed_pipe_is_quiet_exit_141():
    """Issue 33 (15): `pinid info … | head -1` — the reader closed the pipe: no "[Errno 32] Broken pipe" as
    bad input (status 2), but exit status 141 (128 + SIGPIPE) and nothing on stderr (docs/checks.md)."""
    import subprocess
    import sys

    proc = subprocess.Popen(
        [sys.executable, "-m", "pinid.cli", "info", "--urdf", "exo_leg"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    proc.stdout.close()  # the reader is gone before anything is written: the first write fails with EPIPE
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141 and err == "", err


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


@pytest.mark.parametrize(
    "argv, option, kind",
    [
        (["info", "--urdf", "{dev}"], "--urdf", "fifo"),
        (["excite", "--comfort", "{dev}", "-o", "e.json"], "--comfort", "device"),
        (["identify", "--data", "{dev}", "-o", "o"], "--data", "fifo"),
        pytest.param(["info", "--urdf", "{dev}"], "--urdf", "device", marks=SLOW),
        pytest.param(
            ["wearer", "--urdf", "{dev}", "--mass", "75", "--height", "1.78", "--sex", "male", "-o", "w.urdf"],
            "--urdf",
            "device",
            marks=SLOW,
        ),
        pytest.param(["excite", "--spec", "{dev}", "-o", "e.json"], "--spec", "fifo", marks=SLOW),
        pytest.param(["info", "--drives", "{dev}"], "--drives", "device", marks=SLOW),
        pytest.param(["identify", "--data", "r.csv", "--mapping", "{dev}", "-o", "o"], "--mapping", "fifo", marks=SLOW),
        pytest.param(["simulate", "--excitation", "{dev}", "-o", "s.csv"], "--excitation", "device", marks=SLOW),
    ],
)
def test_file_options_refuse_devices_and_fifos(tmp_path, argv, option, kind):
    if kind == "fifo":
        if not hasattr(os, "mkfifo"):
            pytest.skip("no FIFOs here")
        dev = tmp_path / "pipe"
        os.mkfifo(dev)
    else:
        dev = Path("/dev/zero")
        if not dev.exists():
            pytest.skip("no /dev/zero here")
    (tmp_path / "r.csv").write_text("t,q_hip,q_knee,tau_hip,tau_knee\n0,0,0,1,1\n")
    before = _files(tmp_path)
    proc = run_cli(*[a.format(dev=dev) for a in argv], cwd=tmp_path)
    assert_clean_error(proc, f"{option} {dev}", "FIFO" if kind == "fifo" else "device", "regular file")
    assert _files(tmp_path) == before


def _wait_for_numpy(proc: subprocess.Popen, timeout: float = 60.0) -> bool:
    """Wait until the child has mapped numpy's extension (it is loading its modules, inside main()'s
    Ctrl-C guard); False if it ended first."""
    maps = Path(f"/proc/{proc.pid}/maps")
    end = time.monotonic() + timeout
    while time.monotonic() < end and proc.poll() is None:
        try:
            if "_multiarray_umath" in maps.read_text():
                return True
        except OSError:
            return False
        time.sleep(0.002)
    return False


@pytest.mark.skipif(not Path("/proc/self/maps").exists(), reason="needs /proc to see the child's modules load")
def test_ctrl_c_while_starting_gives_one_line(tmp_path, recording):
    """Case 20: SIGINT at several moments from the first extension module on (deterministic: each trial
    starts its clock when the child maps numpy, whatever the machine's speed).  Every trial: no
    traceback, at most one line on stderr, status 130 (interrupted while starting) or 2 (while working)
    or 0 (done before the signal; or killed by it while the interpreter shuts down after the work, with
    nothing on stderr but the run's own warnings), and no output unless it finished."""
    outcomes = []
    for k, delay in enumerate((0.0, 0.01, 0.05, 0.15, 0.3, 0.6)):
        out = tmp_path / f"o{k}"
        argv = ["identify", "--urdf", "exo_leg", "--data", str(recording), "--methods", "ols", "--no-report"]
        proc = subprocess.Popen(
            [sys.executable, "-m", "pinid.cli", *argv, "-o", str(out)],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            started = _wait_for_numpy(proc)
            time.sleep(delay)
            if started and proc.poll() is None:
                proc.send_signal(signal.SIGINT)
            _, err = proc.communicate(timeout=120)
        finally:
            if proc.poll() is None:
                proc.kill()
        lines = err.strip().splitlines()
        assert "Traceback" not in err and "PyCapsule" not in err, (delay, err)
        if proc.returncode == -signal.SIGINT:  # the work was done; the signal met the interpreter's shutdown
            assert all(": warning:" in line for line in lines), (delay, err)  # only the run's own warnings
            assert (out / "identification.json").is_file(), (delay, err)
            continue
        assert proc.returncode in (0, 2, 130), (delay, proc.returncode, err)
        if proc.returncode != 0:
            assert len(lines) == 1 and "interrupted" in lines[0], (delay, err)
            assert not out.exists(), delay
        outcomes.append(proc.returncode)
    assert 130 in outcomes, outcomes  # the early trials land while the modules load
