"""pinid flex (pinid/cli/flex.py): its numbers checked when parsed, its output option like every command's."""

from __future__ import annotations

import pytest
from conftest import assert_clean_error, run_cli


@pytest.mark.parametrize(
    "argv",
    [
        ["flex", "twin", "-o", "t.csv", "--seed", "-1"],
        ["flex", "fit", "-o", "f.json", "--seed", "-1"],
        ["flex", "compare", "-o", "c.json", "--seed", "-1"],
    ],
)
def test_flex_seed_checked_at_parse(tmp_path, argv):
    """Case 5: --seed -1 on every command, flex included."""
    assert_clean_error(run_cli(*argv, cwd=tmp_path), "--seed")
    assert list(tmp_path.iterdir()) == []


def test_flex_output_option_and_out_alias(tmp_path):
    """flex uses -o/--output like every command; --out still works; the recording and its truth are one set."""
    for flag, name in (("-o", "a.csv"), ("--output", "b.csv"), ("--out", "c.csv")):
        proc = run_cli("flex", "twin", flag, name, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        assert (tmp_path / name).is_file() and (tmp_path / f"{name}.json").is_file()
    before = (tmp_path / "a.csv.json").read_bytes()
    (tmp_path / "a.csv").unlink()  # the truth alone is in the way: refused, kept
    assert_clean_error(run_cli("flex", "twin", "-o", "a.csv", cwd=tmp_path), "already exists")
    assert not (tmp_path / "a.csv").exists() and (tmp_path / "a.csv.json").read_bytes() == before
