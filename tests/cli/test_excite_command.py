"""pinid excite (pinid/cli/excite.py): bad specs, comfort files and sizes give one line and exit status 2, with
nothing written."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest
from conftest import assert_clean_error, run_cli

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
