"""docs/getting-started.md runs: its ``bash`` blocks, in order, in a fresh folder, then its Python block.

To stay under a minute the test shortens the recordings (``--seconds 60`` → 15, ``--seconds 30`` → 10)
and the excitation search (``--starts 8`` → 2); the page says so.  The install commands are ``sh``
blocks and are not run (CI installs pinid its own way).
"""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import run_cli

DOC = Path(__file__).resolve().parents[2] / "docs" / "getting-started.md"
SHORTER = {("--seconds", "60"): "15", ("--seconds", "30"): "10", ("--starts", "8"): "2"}


def blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", DOC.read_text(), flags=re.S)


def commands() -> list[list[str]]:
    """The shell commands of the page's bash blocks (comments and blank lines left out), as argv lists."""
    out = []
    for block in blocks("bash"):
        text = re.sub(r"\\\n\s*", " ", block)  # continued lines
        for line in text.splitlines():
            line = line.strip()
            if line and not line.startswith("#"):
                out.append(shlex.split(line))
    return out


def shorter(argv: list[str]) -> list[str]:
    return [SHORTER.get((argv[i - 1], a), a) if i else a for i, a in enumerate(argv)]


def test_the_page_has_the_steps():
    cmds = commands()
    assert [c[:2] for c in cmds] == [
        ["pinid", "info"],
        ["pinid", "excite"],
        ["pinid", "simulate"],
        ["pinid", "simulate"],
        ["pinid", "identify"],
        ["pinid", "track"],
    ]
    written = [a for c in cmds for k, a in enumerate(c) if c[k - 1] in ("-o", "--plot", "--csv")]
    assert written and all(a.startswith("steps/") for a in written), written  # never into the demo's demo/
    assert "activate" in DOC.read_text() and ".venv/bin/pinid" in DOC.read_text()


@pytest.mark.slow
def test_getting_started_runs_in_a_fresh_folder(tmp_path):
    for argv in commands():
        assert argv[0] == "pinid", argv
        proc = run_cli(*shorter(argv)[1:], cwd=tmp_path)
        assert proc.returncode == 0, (argv, proc.stderr[-2000:])
    for name in (
        "excitation.json",
        "train.csv",
        "validate.csv",
        "identification/report.html",
        "identification/model_sdp.json",
        "track/tracking.json",
    ):
        assert (tmp_path / "steps" / name).is_file(), name
    (python,) = blocks("python")
    proc = subprocess.run([sys.executable, "-c", python], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
