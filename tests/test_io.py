"""The one output writer (pinid.io.Artefacts) and the CLI cases of issue 14 it fixes: outputs are all or
nothing, collisions are refused, a failed run leaves no folder, --force removes an earlier run's outputs; and
pinid.io's reading of TOML and JSON specs (too deep a nesting is one line, not a RecursionError)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from conftest import assert_clean_error, run_cli
from pinid.errors import ModelError, OutputError, PinidError, SpecError
from pinid.data.mapping import MappingSpec
from pinid.io import Artefacts


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


def test_writes_all_into_new_folder(tmp_path):
    arts = Artefacts(overwrite=False)
    arts.add(tmp_path / "a" / "b" / "x.json", "{}")
    arts.add(tmp_path / "a" / "y.bin", b"\x00\x01")
    arts.add(tmp_path / "a" / "z.txt", lambda p: p.write_text("z"))
    assert [p.name for p in arts.write()] == ["x.json", "y.bin", "z.txt"]
    assert (tmp_path / "a" / "b" / "x.json").read_text() == "{}"
    assert (tmp_path / "a" / "y.bin").read_bytes() == b"\x00\x01"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a"]  # no staging folder left


def test_failure_leaves_nothing(tmp_path):
    def boom(p):
        p.write_text("half")
        raise KeyboardInterrupt

    arts = Artefacts(overwrite=False)
    arts.add(tmp_path / "out" / "x.json", "{}")
    arts.add(tmp_path / "out" / "y.json", boom)
    with pytest.raises(KeyboardInterrupt):
        arts.write()
    assert list(tmp_path.iterdir()) == []  # no file, no .part, no empty folder


def test_collision_and_existing_refused(tmp_path):
    arts = Artefacts(overwrite=True)
    arts.add(tmp_path / "e.json", "{}")
    arts.add(tmp_path / "." / "e.json", "a,b")
    with pytest.raises(OutputError, match="same file"):
        arts.write()
    (tmp_path / "old.json").write_text("keep")
    arts = Artefacts(overwrite=False)
    arts.add(tmp_path / "new.json", "{}")
    arts.add(tmp_path / "old.json", "{}")
    with pytest.raises(OutputError, match="already exists"):
        arts.write()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.json"]
    assert (tmp_path / "old.json").read_text() == "keep"


def test_unwritable_folder(tmp_path):
    if os.geteuid() == 0:
        pytest.skip("root writes anywhere")
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    arts = Artefacts()
    arts.add(ro / "sub" / "x.json", "{}")
    with pytest.raises(OutputError, match="not writable"):
        arts.write()
    assert list(ro.iterdir()) == []


def test_clean_removes_stale_outputs_only(tmp_path):
    for name in ("model_sdp.json", "identified_sdp.urdf", "notes.txt"):
        (tmp_path / name).write_text("old")
    arts = Artefacts(overwrite=True)
    arts.add(tmp_path / "model_ols.json", "{}")
    arts.clean(tmp_path, ["model_*.json", "identified_*.urdf"])
    arts.write()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model_ols.json", "notes.txt"]


def test_output_error_is_pinid_error():
    assert issubclass(OutputError, PinidError)


# ------------------------------------------------------------------ through the CLI


@pytest.mark.slow
def test_identify_force_removes_stale_outputs(tmp_path, recording):
    """Issue 14 case 13: a --force re-run leaves no output of the earlier run next to the new one."""
    out = tmp_path / "run"
    base = ["identify", "--urdf", "exo_leg", "--data", str(recording), "--no-report", "-o", str(out)]
    first = run_cli(*base, "--methods", "ols,wls")
    assert first.returncode == 0, first.stderr
    assert (out / "model_wls.json").exists()
    (out / "report.md").write_text("old report")
    second = run_cli(*base, "--methods", "ols", "--force")
    assert second.returncode == 0, second.stderr
    names = sorted(p.name for p in out.iterdir())
    assert "model_wls.json" not in names and "report.md" not in names, names
    assert "model_ols.json" in names and "identification.json" in names


def test_failed_identify_leaves_no_folder(tmp_path):
    """Issue 14 case 24: a failed run leaves no empty output folder."""
    out = tmp_path / "never"
    proc = run_cli("identify", "--urdf", "exo_leg", "--data", str(tmp_path / "missing.csv"), "-o", str(out))
    assert_clean_error(proc, "missing.csv")
    assert not out.exists()


def test_sigterm_like_sigint(tmp_path, recording):
    """Issue 14 case 17: SIGTERM is handled like SIGINT: one line, status 2, no output, no .part."""
    import os
    import subprocess
    import sys

    out = tmp_path / "run"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "pinid.cli",
            "identify",
            "--urdf",
            "exo_leg",
            "--data",
            str(recording),
            "--methods",
            "sdp",
            "-o",
            str(out),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONUNBUFFERED": "1"},
    )
    # the first line is printed after the handler is in place (a fixed sleep raced the imports under load)
    proc.stdout.readline()
    proc.terminate()
    _, err = proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.skip("finished before the signal")
    assert proc.returncode == 2, (proc.returncode, err)
    assert len(err.strip().splitlines()) == 1 and "interrupted" in err
    assert not out.exists() or not any(out.rglob("*"))
    assert not any(p.name.startswith(".pinid-") for p in tmp_path.iterdir())


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["excite", "--urdf", "exo_leg", "--seed", "-1"], "--seed"),
        (["simulate", "--urdf", "exo_leg", "--seed", "-1"], "--seed"),
        (["track", "--seed", "-1"], "--seed"),
        (["demo", "--seed", "-1"], "--seed"),
        (["excite", "--urdf", "exo_leg", "--base-frequency", "0"], "--base-frequency"),
        (["excite", "--urdf", "exo_leg", "--base-frequency", "nan"], "--base-frequency"),
        (["identify", "--urdf", "exo_leg", "--data", "x.csv", "--regularization", "-1"], "--regularization"),
        (["identify", "--urdf", "exo_leg", "--data", "x.csv", "--regularization", "nan"], "--regularization"),
        (
            ["identify", "--urdf", "exo_leg", "--data", "x.csv", "--methods", "wls", "--wls-iterations", "0"],
            "--wls-iterations",
        ),
        (
            ["identify", "--urdf", "exo_leg", "--data", "x.csv", "--methods", "wls", "--wls-iterations", "-1"],
            "--wls-iterations",
        ),
        (["track", "--position-noise", "-1"], "--position-noise"),
        (["track", "--position-noise", "nan"], "--position-noise"),
    ],
)
def test_numbers_checked_at_parse(tmp_path, argv, fragment):
    """Issue 14 cases 5, 6 and 21: numbers no run can use are refused before any work, leaving no file."""
    proc = run_cli(*argv, cwd=tmp_path)
    assert_clean_error(proc, fragment)
    assert list(tmp_path.iterdir()) == []


def test_excite_outputs_on_one_path_refused(tmp_path):
    """Issue 14 case 18: two outputs on one path are refused before any work; the existing file stays."""
    proc = run_cli("excite", "--urdf", "exo_leg", "-o", "e.json", "--csv", "e.json", cwd=tmp_path)
    assert_clean_error(proc, "same file")
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "e.json").write_text("keep")
    proc = run_cli("excite", "--urdf", "exo_leg", "-o", "e.json", "--csv", "e.json", "--force", cwd=tmp_path)
    assert_clean_error(proc, "same file")
    assert (tmp_path / "e.json").read_text() == "keep"


def test_an_interrupt_while_workers_start_is_raised_once_they_are_up():
    """deferred_interrupts holds SIGTERM/Ctrl-C while a pool forks its workers (an interrupt there left
    workers no thread would end: the command never exited) and raises it to the handler in place after."""
    import os
    import signal

    from pinid.io import deferred_interrupts

    seen: list[str] = []
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: seen.append("handled"))
    try:
        with deferred_interrupts():
            os.kill(os.getpid(), signal.SIGTERM)
            seen.append("block ended")
        assert seen == ["block ended", "handled"]
        assert signal.getsignal(signal.SIGTERM) is not None and seen.count("handled") == 1
    finally:
        signal.signal(signal.SIGTERM, previous)


# ------------------------------------------------------------------------------------------ written behind
def _pid_text(_):
    return str(os.getpid())


def test_behind_files_are_written_by_another_process_and_waited_for(tmp_path):
    from pinid.io import written_behind, writing_behind

    def slow(_):
        import time

        time.sleep(0.3)
        return str(os.getpid())

    assert not writing_behind()
    with written_behind():
        assert writing_behind()
        arts = Artefacts()
        arts.add(tmp_path / "now.txt", _pid_text)
        arts.add(tmp_path / "later.txt", slow, behind=True)
        assert arts.write() == [tmp_path / "now.txt", tmp_path / "later.txt"]
        assert (tmp_path / "now.txt").read_text() == str(os.getpid())  # written before write() returned
        assert not (tmp_path / "later.txt").exists()  # still being drawn
    assert (tmp_path / "later.txt").read_text() not in ("", str(os.getpid()))  # another process wrote it
    assert sorted(p.name for p in tmp_path.iterdir()) == ["later.txt", "now.txt"]  # no staging folder left


def test_behind_files_outside_the_block_are_written_in_turn(tmp_path):
    arts = Artefacts()
    arts.add(tmp_path / "a.txt", _pid_text, behind=True)
    arts.add(tmp_path / "b.bin", b"\x00\x01")
    arts.write()
    assert (tmp_path / "a.txt").read_text() == str(os.getpid())
    assert (tmp_path / "b.bin").read_bytes() == b"\x00\x01"


def test_an_error_behind_is_raised_at_the_end_of_the_block(tmp_path):
    from pinid.io import written_behind

    def broken(_):
        raise ValueError("the figure could not be drawn")

    with pytest.raises(OutputError, match=r"bad.png \(written behind\): the figure could not be drawn"):
        with written_behind():
            arts = Artefacts()
            arts.add(tmp_path / "ok.txt", "fine")
            arts.add(tmp_path / "bad.png", broken, behind=True)
            arts.write()
    assert not (tmp_path / "bad.png").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ok.txt"]


def test_an_error_in_the_block_stops_the_writers(tmp_path):
    import time

    from pinid.io import written_behind

    def forever(_):
        time.sleep(60)
        return "never"

    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        with written_behind():
            arts = Artefacts()
            arts.add(tmp_path / "late.txt", forever, behind=True)
            arts.write()
            raise KeyboardInterrupt
    assert time.perf_counter() - t0 < 10
    assert not (tmp_path / "late.txt").exists()


def test_bounded_reader(tmp_path):
    from pinid.io import read_bounded_file

    (tmp_path / "a.toml").write_bytes(b"x" * 100)
    assert read_bounded_file(tmp_path / "a.toml", "spec", limit=100) == b"x" * 100
    with pytest.raises(SpecError, match="100 bytes, larger than a spec should be"):
        read_bounded_file(tmp_path / "a.toml", "spec", limit=99)
    with pytest.raises(SpecError, match="--spec .*: is a folder"):
        read_bounded_file(tmp_path, "spec", option="--spec")
    with pytest.raises(ModelError, match="file not found"):
        read_bounded_file(tmp_path / "none.urdf", "URDF", error=ModelError)


def _identify(tmp_path: Path, *args: str):
    out = tmp_path / "results"
    return run_cli("identify", "--urdf", "exo_leg", "--methods", "ols", "--no-report", "-o", str(out), *args), out


@pytest.mark.parametrize("kind", ["arrays", "inline tables", "dotted tables"])
def test_deeply_nested_toml_is_one_line(tmp_path, rec, kind):
    n = 5000
    body = {
        "arrays": "x = " + "[" * n + "]" * n,
        "inline tables": "x = " + "{a = " * n + "1" + "}" * n,
        "dotted tables": "[" + ".".join(["a"] * n) + "]\nb = 1",
    }[kind]
    spec = tmp_path / "deep.toml"
    spec.write_text(body + "\n")
    with pytest.raises(SpecError, match="nested deeper than 64 levels|not valid TOML"):
        MappingSpec.load(spec)
    proc, out = _identify(tmp_path, "--data", str(rec), "--mapping", str(spec))
    assert_clean_error(proc, str(spec))
    assert not out.exists()
    for args in (
        ["info", "--urdf", "exo_leg", "--drives", str(spec)],
        ["excite", "--urdf", "exo_leg", "--spec", str(spec), "-o", str(tmp_path / "e.json")],
        ["flex", "check", "--spec", str(spec)],
    ):
        proc = run_cli(*args)
        assert proc.returncode == 2 and "RecursionError" not in proc.stderr, (args, proc.stderr)
        assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert _files(tmp_path) == ["deep.toml"]


def test_deeply_nested_json_spec(tmp_path):
    spec = tmp_path / "deep.json"
    spec.write_text("[" * 100000 + "]" * 100000)
    proc = run_cli("excite", "--urdf", "exo_leg", "--spec", str(spec), "-o", str(tmp_path / "e.json"))
    assert_clean_error(proc, "nested deeper")
    assert _files(tmp_path) == ["deep.json"]


@pytest.mark.parametrize(
    "argv, folder",
    [
        (["simulate", "--urdf", "exo_leg", "--excitation", "missing.json", "-o", "new/run.csv"], "new"),
        (["compare", "--urdf", "exo_leg", "--data", "missing.csv", "-o", "new"], "new"),
        (["track", "--model", "missing.json", "-o", "new"], "new"),
        (
            ["wearer", "--urdf", "exo_leg", "--mass", "10", "--height", "1.8", "--sex", "male", "-o", "new/w.urdf"],
            "new",
        ),
        (["flex", "twin", "--spec", "missing.toml", "-o", "new/t.csv"], "new"),
        (["flex", "fit", "--spec", "missing.toml", "-o", "new/f.json"], "new"),
        (["flex", "compare", "--spec", "missing.toml", "-o", "new/c.json"], "new"),
        (["flex", "check", "--spec", "missing.toml", "--json", "new/c.json"], "new"),
    ],
)
def test_failed_runs_leave_no_folder(tmp_path, argv, folder):
    """Case 24: a failed run of any command that writes leaves no (empty) output folder."""
    proc = run_cli(*argv, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert not (tmp_path / folder).exists()
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "argv",
    [
        ["simulate", "--urdf", "exo_leg", "--excitation", "zha2019-1", "-o", "x.csv", "--truth", "x.csv"],
        ["simulate", "--urdf", "exo_leg", "--excitation", "zha2019-1", "-o", "x.csv", "--true-signals", "./x.csv"],
        ["flex", "fit", "-o", "x.png", "--plot", "x.png"],
        ["flex", "compare", "-o", "x.png", "--plot", "x.png"],
    ],
)
def test_outputs_on_one_path_refused(tmp_path, argv):
    """Case 18 for the other commands: two outputs on one path are refused before the work."""
    assert_clean_error(run_cli(*argv, cwd=tmp_path), "same file")
    assert list(tmp_path.iterdir()) == []
