"""pinid simulate (pinid/cli/simulate.py): bad outputs, trajectories and robots give one line and exit status 2,
with nothing written or replaced; a trajectory's joints are mapped by name."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_clean_error, run_cli
from conftest import trajectory_file as _trajectory

ROOT = Path(__file__).resolve().parents[2]
EXO = (ROOT / "urdf" / "exo_leg.urdf").read_text()
KNEE_ORIGIN = '<origin xyz="0 0 -0.42" rpy="0 0 0"/>'
EXCITATION = str(ROOT / "excitation" / "exo_leg.json")


def _write(tmp_path, text: str | bytes, name: str = "rec.csv") -> Path:
    p = tmp_path / name
    p.write_bytes(text) if isinstance(text, bytes) else p.write_text(text)
    return p


def test_output_folder_not_writable(tmp_path, good_csv):
    blocker = tmp_path / "file"
    blocker.write_text("I am a file")
    proc = run_cli(
        "simulate", "--excitation", "zha2019-1", "--urdf", "apal_leg", "--seconds", "1", "-o", str(blocker / "run.csv")
    )
    assert_clean_error(proc, "file")
    assert blocker.read_text() == "I am a file"


def test_output_path_is_a_folder(tmp_path):
    proc = run_cli("simulate", "--excitation", "zha2019-1", "--urdf", "apal_leg", "--seconds", "1", "-o", str(tmp_path))
    assert_clean_error(proc, "folder")


def test_malformed_trajectory_json(tmp_path):
    bad = _write(tmp_path, '{"joints": ["hip", "knee"], "q0": [0.6]', "traj.json")
    proc = run_cli("simulate", "--excitation", str(bad), "--seconds", "1", "-o", str(tmp_path / "o.csv"))
    assert_clean_error(proc, "traj.json")
    assert not (tmp_path / "o.csv").exists()


def _urdf(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_simulate_refuses_a_run_that_leaves_the_limits(tmp_path):
    """Item 9: a knee 1e6 m below the hip: the twin says it did not track, and why, and writes nothing."""
    path = _urdf(tmp_path, "far.urdf", EXO.replace(KNEE_ORIGIN, '<origin xyz="0 0 -1e6" rpy="0 0 0"/>'))
    out = tmp_path / "out"
    p = run_cli("simulate", "--urdf", str(path), "--excitation", EXCITATION, "--seconds", "1", "-o", str(out / "r.csv"))
    assert_clean_error(p, "failed to track", "joint 'knee'", "outside its limits", "1e+06 m from its parent joint")
    assert not out.exists()


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_massless_last_link_named_before_simulating(tmp_path):
    i = EXO.index('<link name="shank"')
    shank = re.sub(r'<mass value="[^"]*"', '<mass value="0"', EXO[i:], count=1)
    shank = re.sub(r"<inertia [^/]*/>", '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>', shank, count=1)
    (tmp_path / "m.urdf").write_text(EXO[:i] + shank)
    out = tmp_path / "s.csv"
    proc = run_cli(
        "simulate", "--urdf", str(tmp_path / "m.urdf"), "--excitation", "exo_leg", "--seconds", "2", "-o", str(out)
    )
    assert_clean_error(proc, "joint 'knee' moves no mass or inertia", "link 'shank'", "singular")
    assert _files(tmp_path) == ["m.urdf"]


def test_simulate_maps_trajectory_joints_by_name(tmp_path):
    tr = _trajectory(tmp_path / "tr.json", ["knee", "hip"])
    out = tmp_path / "out.csv"
    proc = run_cli("simulate", "--urdf", "exo_leg", "--excitation", str(tr), "--seconds", "1", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    d = np.genfromtxt(out, delimiter=",", names=True)
    assert d["q_hip"][0] == pytest.approx(0.6, abs=1e-3)  # hip's q0, not knee's
    assert d["q_knee"][0] == pytest.approx(-0.9, abs=1e-3)
    assert np.ptp(d["q_hip"]) < 0.01 < np.ptp(d["q_knee"])  # the knee carries the 0.3 rad harmonic


def test_simulate_unknown_trajectory_joint(tmp_path):
    tr = _trajectory(tmp_path / "tr.json", ["knee", "foo"])
    proc = run_cli(
        "simulate", "--urdf", "exo_leg", "--excitation", str(tr), "--seconds", "1", "-o", str(tmp_path / "o.csv")
    )
    assert_clean_error(proc, "['knee', 'foo']", "['hip', 'knee']")
    assert _files(tmp_path) == ["tr.json"]
