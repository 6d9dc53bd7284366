"""The contract every registered reader and writer keeps (issue 26): iterated over
:data:`pinid.data.registry.READERS` / ``WRITERS``, so a new format is checked without editing this file.
``check_reader`` also runs on the worked example of docs/architecture.md ("Adding a data format").

* every reader reads back what its writer of the same name wrote (or, for a format pinid does not write,
  the file its ``example`` makes): the same t, q, dq and tau, with and without a mapping spec naming the
  format;
* every reader refuses a missing file with a one-line DataError naming it;
* every writer's file is read back by the reader its suffix chooses.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from pinid.data.formats import read_recording
from pinid.data.registry import READERS, WRITERS, Reader, Table, reader_for
from pinid.errors import DataError

JOINTS = ["hip", "knee"]


def recording(n: int = 40):
    """Dataset-format columns (t, q_*, dq_*, tau_*) of a smooth motion, and the arrays by column."""
    t = np.arange(n) / 100.0
    q = np.column_stack([0.3 * np.sin(3 * t), -0.5 + 0.2 * np.cos(2 * t)])
    dq = np.column_stack([0.9 * np.cos(3 * t), -0.4 * np.sin(2 * t)])
    tau = np.column_stack([1.5 + np.sin(t), -2.0 + 0.1 * t])
    names = ["t"] + [f"{p}_{j}" for p in ("q", "dq", "tau") for j in JOINTS]
    return names, np.column_stack([t, q, dq, tau])


def spec(fmt: str) -> dict:
    joints = {j: {"q": f"q_{j}", "dq": f"dq_{j}", "tau": f"tau_{j}"} for j in JOINTS}
    return {"time": "t", "format": fmt, "joints": joints}


def _suffix(reader: Reader) -> str:
    return next((s for s in reader.suffixes if s), ".dat")


def make_file(name: str, folder: Path) -> Path:
    """A recording in format ``name``: written by its writer, else made by the reader's ``example``."""
    reader = READERS[name]
    names, data = recording()
    if name in WRITERS:
        writer = WRITERS[name]
        path = folder / f"rec{writer.suffixes[0]}"
        writer.write(path, names, data, 12)
        return path
    assert reader.example is not None, f"reader {name!r} has neither a writer nor an example file"
    return Path(reader.example(folder / f"rec_{name}", names, data))


def _same(ds, data: np.ndarray) -> None:
    assert ds.joints == JOINTS
    np.testing.assert_allclose(ds.t, data[:, 0], rtol=0, atol=1e-9)
    for k, key in enumerate(("q", "dq", "tau")):
        np.testing.assert_allclose(getattr(ds, key), data[:, 1 + 2 * k : 3 + 2 * k], rtol=1e-10, atol=1e-12)


def check_reader(name: str, folder: Path) -> None:
    """Every clause of the contract for the registered reader ``name``."""
    reader = READERS[name]
    _, data = recording()
    path = make_file(name, folder)
    _same(read_recording(path, mapping=spec(name)), data)  # through a mapping spec naming the format
    if reader.columns is not None:  # a format that can hold pinid's dataset format reads without a spec
        assert reader_for(path).name == name
        _same(read_recording(path), data)
    missing = folder / f"missing{_suffix(reader)}"
    for kw in ({}, {"mapping": spec(name)}):
        with pytest.raises(DataError) as err:
            read_recording(missing, **kw)
        assert "missing" in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("name", sorted(READERS))
def test_every_registered_reader_keeps_the_contract(name, tmp_path):
    check_reader(name, tmp_path)


@pytest.mark.parametrize("name", sorted(WRITERS))
def test_every_writer_is_read_back_by_the_reader_of_its_suffix(name, tmp_path):
    names, data = recording()
    for suffix in WRITERS[name].suffixes:
        path = tmp_path / f"rec{suffix}"
        WRITERS[name].write(path, names, data, 12)
        _same(read_recording(path), data)


# ---------------------------------------------------------------------------------------------- a toy one
def _json_columns(file: Path) -> list[str]:
    try:
        return list(json.loads(file.read_text()))
    except OSError as exc:
        raise DataError(f"{file}: not readable ({exc.strerror})") from None


def _json_read(file: Path, source, wanted, origin: str) -> Table:
    names = _json_columns(file)
    cols = json.loads(file.read_text())
    tab = Table(file, names, {}, len(next(iter(cols.values()))), None)
    for col, index, where in wanted:
        tab.key(col, where, origin)
        tab.data[(col, index)] = np.asarray(cols[col], dtype=float)
    return tab


def test_a_reader_without_writer_or_example_is_refused(monkeypatch, tmp_path):
    monkeypatch.setitem(READERS, "toy_nowrite", Reader("toy_nowrite", _json_read, suffixes=(".tnw",)))
    with pytest.raises(AssertionError, match="neither a writer nor an example"):
        check_reader("toy_nowrite", tmp_path)


def architecture_example(heading: str) -> str:
    """The python block of the section ``heading`` of docs/architecture.md (its worked example; compiled
    with ``dont_inherit`` so that it runs as a file of its own, without this file's ``__future__`` import)."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "architecture.md").read_text(encoding="utf-8")
    section = text.split(f"\n## {heading}\n", 1)[1].split("\n## ", 1)[0]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_worked_example_of_docs_architecture_keeps_the_contract(monkeypatch, tmp_path):
    """docs/architecture.md's "Adding a data format" block, run as written, registers a format that passes."""
    monkeypatch.setitem(READERS, "jcol", None)  # restored (removed) after the test
    monkeypatch.setitem(WRITERS, "jcol", None)
    exec(
        compile(architecture_example("Adding a data format"), "docs/architecture.md", "exec", dont_inherit=True),
        {"__name__": "example"},
    )
    check_reader("jcol", tmp_path)
