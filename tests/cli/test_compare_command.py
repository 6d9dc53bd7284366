"""pinid compare (pinid/cli/compare.py): its options."""

from __future__ import annotations

from conftest import run_cli


def test_compare_takes_the_flag_too():
    assert "--allow-outside-paths" in run_cli("compare", "--help").stdout
