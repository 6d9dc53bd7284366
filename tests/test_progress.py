"""Progress of long work: a line every few seconds on stderr when it is not a terminal (CI, logs, pipes),
--progress/--no-progress on every command (pinid.progress)."""

from __future__ import annotations

import time

import pytest

from pinid import progress as progress_module
from pinid.progress import MODE, Lines, choose, progress


def test_lines_are_sparse_and_end_with_the_final_state(capsys):
    with Lines(10, "work", interval=0.05) as bar:
        for _ in range(10):
            time.sleep(0.03)
            bar.update(1)
            bar.set_postfix_str("best 1.5")
    lines = capsys.readouterr().err.splitlines()
    assert 2 <= len(lines) <= 10, lines  # one per interval (0.3 s / 0.05 s), not one per step
    assert all(line.startswith("pinid: work ") for line in lines)
    assert lines[-1].startswith("pinid: work 10/10 (100 %)") and lines[-1].endswith("best 1.5")


def test_short_work_prints_nothing(capsys):
    with Lines(3, "quick", interval=5.0) as bar:
        bar.update(3)
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize(
    "mode, env, kind",
    [
        ("auto", None, Lines),
        (True, None, Lines),
        (False, None, "silent"),
        (None, None, "silent"),
        ("auto", "0", "silent"),
        (None, "1", Lines),
    ],
)
def test_who_decides(monkeypatch, mode, env, kind):
    """Not a terminal here (pytest captures stderr): the command line prints lines unless --no-progress;
    Python prints nothing; PINID_PROGRESS overrides both."""
    monkeypatch.delenv("PINID_PROGRESS", raising=False)
    if env is not None:
        monkeypatch.setenv("PINID_PROGRESS", env)
    token = MODE.set(mode)
    try:
        bar = progress(5, "x")
        try:
            assert isinstance(bar, Lines) if kind is Lines else bar.disable
        finally:
            bar.close()
        assert progress(5, "x", enabled=False).disable  # the caller's word wins
        forced = progress(5, "x", enabled=True)
        assert isinstance(forced, Lines)
        forced.close()
    finally:
        MODE.reset(token)


def test_a_choose_block_decides_for_work_given_no_choice(monkeypatch):
    """Inside ``choose(False)`` even PINID_PROGRESS=1 shows nothing for work that is given no ``enabled`` (a
    metaheuristic's search in a comparison's worker); ``choose(None)`` keeps the outer block's choice; a
    caller's explicit ``enabled`` still wins; a wrong value is a SpecError."""
    from pinid.errors import SpecError

    monkeypatch.setenv("PINID_PROGRESS", "1")
    with choose(False):
        assert progress(5, "x").disable
        with choose(None):
            assert progress(5, "x").disable
        forced = progress(5, "x", enabled=True)
        assert isinstance(forced, Lines)
        forced.close()
    monkeypatch.setenv("PINID_PROGRESS", "0")
    with choose(True):
        bar = progress(5, "x")
        assert isinstance(bar, Lines)
        bar.close()
    assert progress(5, "x").disable  # after the block: the rules again
    with pytest.raises(SpecError, match="enabled"):
        with choose("yes"):
            pass


def test_cli_flag_on_a_long_command(tmp_path, monkeypatch, capsys):
    """pinid excite prints progress lines when stderr is not a terminal, and none with --no-progress."""
    from pinid.cli.main import main

    monkeypatch.delenv("PINID_PROGRESS", raising=False)
    monkeypatch.setattr(progress_module, "INTERVAL", 0.2)
    args = ["excite", "--urdf", "exo_leg", "--starts", "3", "--option", "polish=1"]
    assert main(args + ["-o", str(tmp_path / "a.json")]) == 0
    err = capsys.readouterr().err
    assert "pinid: slsqp " in err, err
    assert main(args + ["-o", str(tmp_path / "b.json"), "--no-progress"]) == 0
    assert capsys.readouterr().err == ""
    assert MODE.get() is None  # main() leaves no setting behind


def test_every_command_has_the_flag():
    from pinid.cli.main import build_parser

    parser = build_parser()
    for argv in (
        ["demo", "--no-progress"],
        ["identify", "--data", "x.csv", "--progress"],
        ["flex", "compare", "-o", "c.json", "--no-progress"],
        ["excite", "--no-progress"],
    ):
        args = parser.parse_args(argv)
        assert args.progress is (argv[-1] == "--progress"), argv
