"""Every fenced code block of README.md, docs/*.md and docs/tutorials/*.md that is meant to run, runs.

Each page runs in a fresh temporary folder laid out like the repository's root, as the docs assume:
``urdf/``, ``excitation/`` and ``docs/examples/`` are *copies* of the repository's (so a command writing
there writes into the copy), and the page's blocks run in order in that folder:

* ```` ```python ```` — ``python -c BLOCK``;
* ```` ```bash ````, ```` ```sh ````, ```` ```shell ```` — each command (``\\``-continued lines joined, comments
  dropped) must be ``pinid …``; it runs as ``python -m pinid.cli …`` and must exit 0;
* ```` ```console ```` — lines ``$ pinid …`` run the same way; the other lines are its output, and each must
  be a line of what the command printed (``...`` stands for anything, runs of spaces for any spacing);
* an untagged block whose first line is a command (``pinid …``, ``$ …``, ``python …``) counts as ``bash``;
  any other block (TOML, JSON, XML, text, an untagged listing) is not run.

An HTML comment on the line before the fence says how a block is taken (the test fails on a block that
is code, unmarked and does not run, so a new block runs or says why not):

* ``<!-- snippet: skip (reason) -->`` — not run (installs, benchmarks, hour-long runs, fragments);
* ``<!-- snippet: with FILE … -->`` — run once the test has put FILE … in the folder: a ``*.csv`` is a
  short twin recording of exo_leg (the first on excitation/exo_leg.json, the others on
  seed001_table3), a ``*.truth.json`` the truth of the first, ``results/`` that recording identified
  (``pinid identify --methods ols,sdp``);
* ``<!-- snippet: file NAME -->`` before a listing — its text is written to NAME (a spec the next block
  reads).
"""

from __future__ import annotations

import importlib.util
import os
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from conftest import run_cli

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *sorted((ROOT / "docs" / "tutorials").glob("*.md"))]
SHELL = ("bash", "sh", "shell")
FENCE = re.compile(r"^(?P<indent>[ \t]*)```(?P<lang>[\w-]*)[^\n]*\n(?P<body>.*?)^(?P=indent)```[ \t]*$", re.S | re.M)
MARK = re.compile(r"<!--\s*snippet:\s*(?P<kind>skip|with|file)\b\s*(?P<arg>.*?)\s*-->")


@dataclass
class Block:
    page: Path
    line: int
    lang: str  # python, bash, console, or "" for a listing
    body: str
    mark: str | None  # skip, with, file
    arg: str

    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"


def blocks(page: Path) -> list[Block]:
    """The page's fenced blocks with their language (``bash`` for an untagged command) and marker."""
    text = page.read_text(encoding="utf-8")
    out = []
    for m in FENCE.finditer(text):
        lang, body = m["lang"], m["body"]
        if lang in SHELL:
            lang = "bash"
        elif lang == "" and re.match(r"\s*(pinid [a-z]+\b(?!:)|\$ |python )", body):
            lang = "console" if body.lstrip().startswith("$ ") else "bash"
        elif lang not in ("python", "console"):
            lang = ""
        before = text[: m.start()].rstrip().rsplit("\n", 1)[-1]
        mark = MARK.search(before)
        line = text[: m.start()].count("\n") + 1
        out.append(Block(page, line, lang, body, mark["kind"] if mark else None, mark["arg"] if mark else ""))
    return out


ALL = [b for page in PAGES for b in blocks(page)]


def commands(body: str) -> list[list[str]]:
    """The shell commands of a block, as argv lists (continued lines joined, comments dropped)."""
    text = re.sub(r"\\\n\s*", " ", body)
    return [
        shlex.split(line, comments=True)
        for line in text.splitlines()
        if line.strip() and not line.lstrip().startswith("#")
    ]


def test_every_code_block_runs_or_says_why_not():
    """A marker on each block that is not run says why; the counts show what the pages hold."""
    code = [b for b in ALL if b.lang]
    skipped = [b for b in code if b.mark == "skip"]
    assert all(re.fullmatch(r"\(.+\)", b.arg) for b in skipped), [b.where() for b in skipped if not b.arg]
    assert all(b.mark in (None, "skip", "with") for b in code), [b.where() for b in code if b.mark == "file"]
    assert all(not b.lang for b in ALL if b.mark == "file")
    for b in code:
        if b.lang in ("bash", "console") and b.mark != "skip":
            cmds = (
                commands(b.body)
                if b.lang == "bash"
                else [shlex.split(x[2:]) for x in b.body.splitlines() if x.startswith("$ ")]
            )
            assert cmds and all(c[0] == "pinid" for c in cmds), (b.where(), "not pinid commands: mark it skip")
    run = len(code) - len(skipped)
    assert run >= 15 and len(skipped) >= 20, (run, len(skipped))  # the pages on 2026-11-24: 15 run, 39 skipped


def _recordings(folder: Path) -> dict[str, Path]:
    """Two short exo_leg twin recordings (train: exo_leg.json, other: seed001_table3) and the first's truth."""
    for name, exc, seed in (("train.csv", "exo_leg", "1"), ("other.csv", "seed001_table3", "2")):
        proc = run_cli(
            "simulate",
            "--urdf",
            "exo_leg",
            "--excitation",
            exc,
            "--seconds",
            "8",
            "--seed",
            seed,
            "--no-progress",
            "-o",
            str(folder / name),
        )
        assert proc.returncode == 0, proc.stderr
    proc = run_cli(
        "identify",
        "--urdf",
        "exo_leg",
        "--data",
        str(folder / "train.csv"),
        "--validate",
        str(folder / "other.csv"),
        "--methods",
        "ols,sdp",
        "--no-figures",
        "--no-progress",
        "-o",
        str(folder / "results"),
    )
    assert proc.returncode == 0, proc.stderr
    return {
        "train": folder / "train.csv",
        "other": folder / "other.csv",
        "truth": folder / "train.truth.json",
        "results": folder / "results",
    }


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    return _recordings(tmp_path_factory.mktemp("inputs"))


def _provide(block: Block, folder: Path, inputs: dict[str, Path]) -> None:
    """Put the files a ``with`` marker names into the folder."""
    csvs = 0
    for name in block.arg.split("(")[0].split():
        target = folder / name
        target.parent.mkdir(parents=True, exist_ok=True)
        if name.rstrip("/") == "results" or name.endswith("/"):
            shutil.copytree(inputs["results"], target, dirs_exist_ok=True)
        elif name.endswith(".truth.json"):
            shutil.copy(inputs["truth"], target)
        elif name.endswith(".csv"):
            shutil.copy(inputs["train" if csvs == 0 else "other"], target)
            csvs += 1
        else:
            raise AssertionError(f"{block.where()}: snippet: with {name}: the test does not know how to make it")


def _matches(expected: str, printed: list[str]) -> bool:
    """An output line of a console block (``...``: anything; spaces: any spacing) is a printed line."""
    pattern = r"\s+".join(".*".join(map(re.escape, part.split("..."))) for part in expected.split())
    return any(re.fullmatch(r"\s*" + pattern + r"\s*", line) for line in printed)


def _run_block(block: Block, folder: Path, inputs) -> None:
    if block.mark == "with":
        _provide(block, folder, inputs)
    if block.lang == "python":
        if re.search(r"^import mujoco\b", block.body, re.M) and importlib.util.find_spec("mujoco") is None:
            pytest.skip(f"{block.where()}: needs MuJoCo (a test dependency from Python 3.11 on)")
        env = {**os.environ, "MPLBACKEND": "Agg", "PINID_PROGRESS": "0"}
        proc = subprocess.run(
            [sys.executable, "-c", block.body], cwd=folder, capture_output=True, text=True, timeout=300, env=env
        )
        assert proc.returncode == 0, (block.where(), proc.stderr[-3000:])
        return
    if block.lang == "bash":
        for argv in commands(block.body):
            proc = run_cli(*argv[1:], "--no-progress", cwd=folder)
            assert proc.returncode == 0, (block.where(), argv, proc.stderr[-3000:])
        return
    lines = block.body.splitlines()  # console: $ commands, each followed by lines of its output
    for k, line in enumerate(lines):
        if not line.startswith("$ "):
            continue
        proc = run_cli(*shlex.split(line[2:])[1:], "--no-progress", cwd=folder)
        assert proc.returncode == 0, (block.where(), line, proc.stderr[-3000:])
        printed = proc.stdout.splitlines()
        for expected in lines[k + 1 :]:
            if expected.startswith("$ "):
                break
            assert _matches(expected, printed), (block.where(), expected, proc.stdout)


def _layout(folder: Path) -> None:
    """The repository's root as the docs assume it: copies of urdf/, excitation/ and docs/examples/."""
    for name in ("urdf", "excitation", "docs/examples"):
        shutil.copytree(ROOT / name, folder / name, symlinks=False)


RUN = [p for p in PAGES if any(b.lang and b.mark != "skip" for b in blocks(p))]


# Every page runs twins, identifications or designs (the floating-base page minutes on a loaded 2-core
# machine): slow, run by the README's whole-suite command and CI's 3.11 stage.
@pytest.mark.slow
@pytest.mark.parametrize("page", RUN, ids=[str(p.relative_to(ROOT)) for p in RUN])
def test_page_blocks_run(page, tmp_path, request):
    """The page's blocks that are meant to run, in order, in one folder laid out like the repository."""
    _layout(tmp_path)
    todo = [b for b in blocks(page) if b.mark != "skip" and (b.lang or b.mark == "file")]
    inputs = request.getfixturevalue("inputs") if any(b.mark == "with" for b in todo) else None
    for b in todo:
        if b.mark == "file":
            (tmp_path / b.arg.split()[0]).write_text(b.body, encoding="utf-8")
        else:
            _run_block(b, tmp_path, inputs)


def test_readme_wearer_row_says_what_the_command_adds(tmp_path):
    """README's `pinid wearer` row: the default adds the thigh and shank, its --attach example the foot too."""
    from pinid.cli.main import build_parser
    from pinid.wearer.attach import wearer_links, wearer_urdf

    (row,) = [line for line in (ROOT / "README.md").read_text().splitlines() if line.startswith("| `pinid wearer")]
    assert "thigh and shank strapped" in row
    attach = re.search(r"`--attach (\S+)` adds the foot", row)[1]
    sub = next(a for a in build_parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    default = sub.choices["wearer"].get_default("attach")
    for value, segments in ((default, ["thigh", "shank"]), (attach, ["thigh", "shank", "foot"])):
        text = wearer_urdf("exo_leg", value, mass=75, height=1.78, sex="male")
        assert sorted(wearer_links(text)) == sorted(segments), value
