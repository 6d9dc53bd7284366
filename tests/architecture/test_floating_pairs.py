"""Issue 32: no function, class or module exists twice for fixed and floating bases.  A public name with
"floating" in it whose name without it (``prepare_floating`` → ``prepare``, ``FloatingRecording`` →
``Recording``, ``simulate_floating_and_write`` → ``simulate_and_write``) is also a public definition of pinid is a
twin pair; the pairs left to merge are listed and the list may only shrink."""

from __future__ import annotations

import re

from test_public_api import _modules, public_definitions

#: Twin pairs still to merge into one (floating name → its fixed-base twin): none.  Identification, comparison,
#: results, files, loaders, the model layer, the setup, the CLI's mapping option, the twin's writer
#: (simulate_and_write), the preparation (``prepare`` hands a floating recording to its ``samples``) and the twin
#: (``simulate`` of a floating model runs the floating twin; its run is ``TwinRun``, unpacked as ``(recording,
#: truth)``) are one pipeline (issue 32).
LEFT_TO_MERGE: dict[str, str] = {}
#: Names that match the pattern without being twins: what each is instead.
NOT_TWINS: dict[str, str] = {
    "FloatingRobotModel": "a RobotModel subclass: the floating robot is a RobotModel with a free-flyer root",
    "add_floating_arguments": "the --rows/--base-weight/--swing-rows option group, not a command's arguments",
}


def twin_name(name: str) -> str:
    """``name`` without its "floating" word: ``prepare_floating`` → ``prepare``, ``FloatingRecording`` →
    ``Recording``, ``simulate_floating_and_write`` → ``simulate_and_write``."""
    out = re.sub(r"_floating(?=_|$)|^floating_|Floating", "", name)
    return out


def twin_pairs() -> dict[str, str]:
    """``{floating name: fixed-base name}`` of the public definitions with both names."""
    where = public_definitions(_modules())
    return {n: twin_name(n) for n in where if "loating" in n and twin_name(n) != n and twin_name(n) in where}


def test_twin_name():
    assert twin_name("prepare_floating") == "prepare" and twin_name("FloatingRecording") == "Recording"
    assert twin_name("simulate_floating_and_write") == "simulate_and_write"
    assert twin_name("floating_problem") == "problem" and twin_name("as_floating") == "as"


def test_no_fixed_and_floating_twins_but_those_left_to_merge():
    pairs = twin_pairs()
    new = {k: v for k, v in pairs.items() if k not in LEFT_TO_MERGE and k not in NOT_TWINS}
    assert not new, f"a fixed/floating twin pair (merge them into one, as identify and compare are): {new}"
    merged = sorted(set(LEFT_TO_MERGE) - set(pairs))
    assert not merged, f"merged, take off LEFT_TO_MERGE: {merged}"
