"""The shape of the command-line modules (docs/architecture.md): each command's ``run()`` parses, calls the
package and prints, in at most 40 lines; the help texts name the estimators of the registry."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

CLI = Path(__file__).resolve().parents[2] / "pinid" / "cli"

#: Longest ``run()`` of a command module, in lines (its ``def`` line to its last line).
MAX_RUN_LINES = 40


def run_lengths() -> dict[str, int]:
    """``{module file name: lines of its run()}`` for every module of pinid/cli that defines ``run``."""
    out = {}
    for path in sorted(CLI.glob("*.py")):
        for node in ast.parse(path.read_text(encoding="utf-8")).body:
            if isinstance(node, ast.FunctionDef) and node.name == "run":
                out[path.name] = node.end_lineno - node.lineno + 1
    return out


def test_every_command_has_a_run():
    from pinid.cli.main import COMMANDS

    assert {f"{name}.py" for name in COMMANDS} <= set(run_lengths())


def test_every_run_is_at_most_40_lines():
    long = {name: n for name, n in run_lengths().items() if n > MAX_RUN_LINES}
    assert not long, f"run() over {MAX_RUN_LINES} lines (move the work into the package): {long}"


@pytest.mark.parametrize("command", ["identify", "compare"])
def test_help_names_every_registered_estimator(command):
    """The help of the commands that run estimators is generated from the registry: every name is in it,
    in the description (the list of methods) as well as in --methods."""
    import argparse

    from pinid.cli.main import build_parser
    from pinid.estimators import ESTIMATORS

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    parser = sub.choices[command]
    words = set(parser.description.replace(",", " ").replace(";", " ").split())
    missing = [name for name in ESTIMATORS if name not in words]
    assert not missing, f"pinid {command} --help's description does not name {missing}"
    text = parser.format_help()
    assert all(name in text for name in ESTIMATORS)
