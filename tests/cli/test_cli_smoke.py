"""The command as a real process (the other CLI tests call ``pinid.cli.main`` in the test's process,
:func:`conftest.run_cli`): help, version, one identification, and a bad input's exit status 2 with one
line and no traceback."""

from __future__ import annotations

import pytest

from conftest import assert_clean_error, run_cli_subprocess

from pinid import __version__


def test_help_lists_every_command():
    from pinid.cli.main import COMMANDS

    proc = run_cli_subprocess("--help")
    assert proc.returncode == 0, proc.stderr
    assert all(name in proc.stdout for name in COMMANDS), proc.stdout


def test_version():
    proc = run_cli_subprocess("--version")
    assert proc.returncode == 0 and proc.stdout.strip() == f"pinid {__version__}", (proc.stdout, proc.stderr)


@pytest.mark.slow  # a real process: 2.2 s; the full suite runs it
def test_one_identification(recording, tmp_path):
    out = tmp_path / "r"
    proc = run_cli_subprocess(
        "identify", "--urdf", "exo_leg", "--data", str(recording), "--methods", "ols", "-o", str(out)
    )
    assert proc.returncode == 0, proc.stderr
    assert (out / "identification.json").is_file()


def test_bad_input_is_status_2_one_line(tmp_path):
    proc = run_cli_subprocess(
        "identify", "--urdf", "exo_leg", "--data", str(tmp_path / "none.csv"), "-o", str(tmp_path / "o")
    )
    assert_clean_error(proc, "none.csv")
    assert not (tmp_path / "o").exists()
