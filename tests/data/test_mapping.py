"""Mapping specs (pinid/data/mapping.py): source paths stay in the recording's folder (issue 14), a file that is
not a recording is never echoed, only the documented placeholders, substituted literally, one rule for column
indices.  Each bad spec is a SpecError from Python, one line and exit status 2 from the CLI with nothing written."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli
from pinid.data.formats import read_recording
from pinid.data.mapping import MappingSpec
from pinid.errors import DataError, SpecError


SECRET = "top-secret-line-do-not-print"


def _spec(torque_path: str, column="k_hip") -> dict:
    return {
        "time": "t",
        "joints": {
            "hip": {"q": "q_hip", "tau": {"source": "x", "column": column}},
            "knee": {"q": "q_knee", "tau": {"source": "x", "column": "k_knee"}},
        },
        "sources": {"x": {"path": torque_path}},
    }


def _toml(d: dict) -> str:
    x = d["sources"]["x"]["path"]
    col = d["joints"]["hip"]["tau"]["column"]
    col = f'"{col}"' if isinstance(col, str) else col
    return (
        f'time = "t"\n[joints.hip]\nq = "q_hip"\ntau = {{ source = "x", column = {col} }}\n'
        f'[joints.knee]\nq = "q_knee"\ntau = {{ source = "x", column = "k_knee" }}\n'
        f'[sources.x]\npath = "{x}"\n'
    )


def _identify(tmp_path: Path, *args: str):
    out = tmp_path / "results"
    return run_cli("identify", "--urdf", "exo_leg", "--methods", "ols", "--no-report", "-o", str(out), *args), out


@pytest.mark.parametrize("where", ["absolute", "climbing", "symlink"])
def test_source_path_outside_the_folder_is_refused(tmp_path, rec, where):
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.csv").write_text(f"{SECRET},x\n1,2\n")
    path = {"absolute": str(outside / "secret.csv"), "climbing": "../../outside/secret.csv", "symlink": "link.csv"}[
        where
    ]
    if where == "symlink":
        link = rec.parent / "link.csv"
        if not link.exists():
            os.symlink(outside / "secret.csv", link)
    if where == "climbing":  # the recording two levels below tmp_path
        data = tmp_path / "a" / "b"
        data.mkdir(parents=True)
        (data / "run.csv").write_text(rec.read_text())
        recording = data / "run.csv"
    else:
        recording = rec
    with pytest.raises(SpecError, match="leads outside"):
        read_recording(recording, mapping=_spec(path))
    spec = tmp_path / "m.toml"
    spec.write_text(_toml(_spec(path)))
    proc, out = _identify(tmp_path, "--data", str(recording), "--mapping", str(spec))
    assert_clean_error(proc, "leads outside", "--allow-outside-paths")
    assert SECRET not in proc.stderr and not out.exists()
    # allowed explicitly: read, and the file (not a recording of these columns) is not echoed
    with pytest.raises(SpecError) as info:
        read_recording(recording, mapping=_spec(path), allow_outside_paths=True)
    assert SECRET not in str(info.value) and "not shown" in str(info.value)
    proc, out = _identify(tmp_path, "--data", str(recording), "--mapping", str(spec), "--allow-outside-paths")
    assert_clean_error(proc, "not shown")
    assert SECRET not in proc.stderr and not out.exists()


def test_source_path_inside_the_folder_still_works(rec):
    ds = read_recording(rec, mapping=_spec("{stem}_torque.csv"))
    assert ds.tau.shape == (2000, 2)
    assert ds.tau[0, 0] == pytest.approx(5.0)


@pytest.mark.parametrize("header", [True, False])
def test_a_file_that_is_not_a_recording_is_not_echoed(tmp_path, rec, header):
    (rec.parent / "notes.csv").write_text(f"{SECRET} one,{SECRET} two\n{SECRET},x\n")
    spec = _spec("notes.csv", column=0 if not header else "k_hip")
    spec["sources"]["x"]["header"] = header
    if not header:
        spec["joints"]["knee"]["tau"]["column"] = 1
    with pytest.raises((SpecError, DataError)) as info:
        read_recording(rec, mapping=spec)
    assert SECRET not in str(info.value)


def test_an_npz_that_is_not_a_recording_is_not_echoed(rec):
    np.savez(rec.parent / "other.npz", **{SECRET: np.zeros(3)})
    for column in ("k_hip", 0):
        spec = _spec("other.npz", column=column)
        with pytest.raises(SpecError) as info:
            read_recording(rec, mapping=spec)
        assert SECRET not in str(info.value)


@pytest.mark.parametrize(
    "path, fragment",
    [
        ("{foo}.csv", "unknown placeholder {foo}"),
        ("{0}.csv", "unknown placeholder {0}"),
        ("{stem.__class__.__doc__}", "unknown placeholder {stem.__class__.__doc__}"),
        ("{stem!r}.csv", "unknown placeholder"),
        ("run{.csv", "unmatched brace"),
        ("run}.csv", "unmatched brace"),
    ],
)
def test_source_path_placeholders(tmp_path, rec, path, fragment):
    with pytest.raises(SpecError, match="expected {stem}, {name}, {suffix}") as info:
        MappingSpec.load(_spec(path))
    assert fragment in str(info.value)
    assert "Return a nice string" not in str(info.value) and "str(object=" not in str(info.value)
    spec = tmp_path / "m.toml"
    spec.write_text(_toml(_spec(path)))
    proc, out = _identify(tmp_path, "--data", str(rec), "--mapping", str(spec))
    assert_clean_error(proc, fragment)
    assert not out.exists()


def test_placeholders_are_substituted_literally(tmp_path):
    folder = tmp_path / "d"
    folder.mkdir()
    name = "x{stem}y"  # a main file whose name has braces: substituted as text, never parsed again
    t = np.arange(100) / 100.0
    (folder / f"{name}.csv").write_text("t,q_hip,q_knee\n" + "".join(f"{a},0.1,-0.2\n" for a in t))
    (folder / f"{name}_tau.csv").write_text("k_hip,k_knee\n" + "".join("1,2\n" for _ in t))
    ds = read_recording(folder / f"{name}.csv", mapping=_spec("{stem}_tau.csv"))
    assert ds.tau[0].tolist() == [1.0, 2.0]


@pytest.mark.parametrize("q", [-4, {"column": -4}])
def test_negative_column_index_is_refused_in_both_forms(tmp_path, rec, q):
    spec = {"time": "t", "joints": {"hip": {"q": q}, "knee": {"q": "q_knee"}}}
    with pytest.raises(SpecError, match="0-based index >= 0"):
        MappingSpec.load(spec)
    toml = tmp_path / "m.toml"
    toml.write_text(
        'time = "t"\n[joints.hip]\nq = '
        + ("-4" if q == -4 else "{ column = -4 }")
        + '\ntau = "tau_hip"\n[joints.knee]\nq = "q_knee"\ntau = "tau_knee"\n'
    )
    proc, out = _identify(tmp_path, "--data", str(rec), "--mapping", str(toml))
    assert_clean_error(proc, "-4", "0-based index >= 0")
    assert not out.exists()
