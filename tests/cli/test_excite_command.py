"""pinid excite (pinid/cli/excite.py): bad specs, comfort files, sizes and optimiser options give one line and
exit status 2, with nothing written; --evaluate maps a trajectory's joints by name."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest
from conftest import assert_clean_error, run_cli
from conftest import trajectory_file as _trajectory

from pinid.errors import OutputError
from pinid.io import Artefacts

ROOT = Path(__file__).resolve().parents[2]


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_outputs_through_a_symlinked_folder_collide(tmp_path):
    """Item 2: -o link/e.json and --csv target/e.json are one file."""
    (tmp_path / "target").mkdir()
    (tmp_path / "link").symlink_to("target")
    p = run_cli(
        "excite",
        "--urdf",
        "exo_leg",
        "-o",
        str(tmp_path / "link" / "e.json"),
        "--csv",
        str(tmp_path / "target" / "e.json"),
    )
    assert_clean_error(p, "two outputs of this run would be written to the same file")
    assert _files(tmp_path) == []
    (tmp_path / "target" / "a.txt").write_text("old")
    os.link(tmp_path / "target" / "a.txt", tmp_path / "b.txt")  # a hard link: one file, two names
    out = Artefacts(overwrite=True)
    out.add(tmp_path / "b.txt", "1")
    out.add(tmp_path / "link" / "a.txt", "2")
    with pytest.raises(OutputError, match="same file"):
        out.write()
    assert (tmp_path / "b.txt").read_text() == "old"


@pytest.mark.parametrize(
    "value", ["0", pytest.param("-1.0", marks=pytest.mark.slow), pytest.param("nan", marks=pytest.mark.slow)]
)
def test_spec_base_frequency_not_positive(tmp_path, value):
    spec = (ROOT / "excitation" / "exo_leg_table2.toml").read_text()
    spec = re.sub(r"(?m)^base_frequency = .*$", f"base_frequency = {value}", spec)
    (tmp_path / "s.toml").write_text(spec)
    proc = run_cli("excite", "--urdf", "exo_leg", "--spec", str(tmp_path / "s.toml"), "-o", str(tmp_path / "e.json"))
    assert_clean_error(proc, "s.toml", "base_frequency", "expected a number > 0")
    assert _files(tmp_path) == ["s.toml"]


def test_comfort_file_nested_deep(tmp_path):
    (tmp_path / "c.toml").write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    proc = run_cli("excite", "--urdf", "exo_leg", "--comfort", str(tmp_path / "c.toml"), "-o", str(tmp_path / "e.json"))
    assert_clean_error(proc, "c.toml", "nested deeper than 64 levels")


def test_excite_samples_beyond_memory(tmp_path):
    from pinid.memory import available_bytes

    if available_bytes() is None:
        pytest.skip("available memory unknown here")
    proc = run_cli("excite", "--urdf", "exo_leg", "--samples", "100000000", "-o", str(tmp_path / "e.json"))
    assert_clean_error(proc, "samples=100000000", "--samples", "of memory", "available")
    assert not (tmp_path / "e.json").exists()


def test_excite_evaluate_maps_trajectory_joints_by_name(tmp_path):
    ordered = _trajectory(tmp_path / "hk.json", ["hip", "knee"])
    d = json.loads(ordered.read_text())
    swapped = tmp_path / "kh.json"
    swapped.write_text(
        json.dumps({**d, "joints": ["knee", "hip"], "q0": d["q0"][::-1], "a": d["a"][::-1], "b": d["b"][::-1]})
    )
    said = [run_cli("excite", "--urdf", "exo_leg", "--evaluate", str(p)) for p in (ordered, swapped)]
    assert [p.returncode for p in said] == [0, 0], said[1].stderr
    cond = [
        next(ln.split("condition number ")[1].split()[0] for ln in p.stdout.splitlines() if "condition number" in ln)
        for p in said
    ]
    assert cond[0] == cond[1]


@pytest.mark.parametrize("value", ["abc", "nan", "inf", "true"])
def test_excite_option_value_checked(tmp_path, value):
    """Case 6: --option w_min=abc|nan is one line naming the option, before any work."""
    proc = run_cli(
        "excite", "--urdf", "exo_leg", "--optimizer", "pso", "--option", f"w_min={value}", "-o", "e.json", cwd=tmp_path
    )
    assert_clean_error(proc, "w_min")
    assert list(tmp_path.iterdir()) == []


def test_excite_unknown_option_names_only_unknown(tmp_path):
    """Case 20: --starts 2 --option foo=bar names foo as unknown, not starts."""
    proc = run_cli("excite", "--urdf", "exo_leg", "--starts", "2", "--option", "foo=bar", "-o", "e.json", cwd=tmp_path)
    assert_clean_error(proc, "unknown option(s) foo (")
    assert "starts, foo" not in proc.stderr
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "extra",
    [["--optimizer", "pso"], ["--optimizer", "slsqp"], ["--starts", "3"], ["--seed", "2"], ["--option", "polish=1"]],
)
def test_excite_evaluate_refuses_optimizer_options(tmp_path, extra):
    """Case 25: an optimiser option has no effect with --evaluate: refused, not silently ignored."""
    from pinid.resources import EXCITATION_DIR

    traj = EXCITATION_DIR / "seed001_table3.json"
    proc = run_cli("excite", "--urdf", "exo_leg", "--evaluate", str(traj), *extra, cwd=tmp_path)
    assert_clean_error(proc, extra[0], "no effect with --evaluate")
