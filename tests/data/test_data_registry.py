"""File formats as a registry: a new reader/writer is one registration; flexible-joint recordings use it too."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pinid.data.dataset import Dataset
from pinid.data.formats import read_recording, write_recording
from pinid.data.registry import READERS, WRITERS, Reader, Table, Writer, reader_for, register_reader, register_writer
from pinid.errors import DataError


def _json_columns(file: Path) -> list[str]:
    return list(json.loads(file.read_text()))


def _json_read(file: Path, source, wanted, origin: str) -> Table:
    cols = json.loads(file.read_text())
    tab = Table(file, list(cols), {}, len(next(iter(cols.values()))), None)
    for col, index, where in wanted:
        tab.key(col, where, origin)
        tab.data[(col, index)] = np.asarray(cols[col], dtype=float)
    return tab


def _json_write(tmp: Path, names, data, digits) -> None:
    tmp.write_text(json.dumps({n: data[:, i].tolist() for i, n in enumerate(names)}))


@pytest.fixture
def json_format():
    register_reader(Reader("json-columns", _json_read, suffixes=(".jcol",), columns=_json_columns))
    register_writer(Writer("json-columns", _json_write, suffixes=(".jcol",)))
    yield
    READERS.pop("json-columns")
    WRITERS.pop("json-columns")


def test_a_registered_format_reads_and_writes_like_the_built_in_ones(tmp_path, json_format, exo):
    t = np.arange(50) / 100.0
    q = np.column_stack([0.3 * np.sin(t), -0.5 + 0.2 * np.cos(t)])
    ds = Dataset(t, q, exo.joint_names, tau=np.ones((50, 2)), source="mem")
    path = write_recording(tmp_path / "run.jcol", ds)
    back = read_recording(path, model=exo)
    np.testing.assert_array_equal(back.q, q)
    # and through a mapping spec naming its columns
    spec = {
        "time": "t",
        "joints": {"hip": {"q": "q_hip", "tau": "tau_hip"}, "knee": {"q": "q_knee", "tau": "tau_knee"}},
    }
    np.testing.assert_array_equal(read_recording(path, mapping=spec).tau, np.ones((50, 2)))
    assert reader_for(path).name == "json-columns"


def test_unknown_suffixes_name_the_registered_ones(tmp_path):
    with pytest.raises(DataError, match=r"unknown suffix '\.xyz', expected \.csv or \.npz"):
        write_recording(tmp_path / "x.xyz", Dataset(np.arange(3.0), np.zeros((3, 1)), ["a"]))
    with pytest.raises(DataError, match=r"unknown file type '\.xyz'.*\.npz"):
        reader_for(tmp_path / "x.xyz")


def test_flexible_recordings_use_the_same_readers_and_writers(tmp_path):
    from pinid.flexible.recording import FlexRecording

    t = np.arange(20) * 0.01
    rec = FlexRecording(t, np.sin(t)[:, None], np.cos(t)[:, None], ["j"], qm=np.cos(2 * t)[:, None])
    for name in ("rec.csv", "rec.npz"):
        back = FlexRecording.load(rec.save(tmp_path / name))
        np.testing.assert_allclose(back.q, rec.q, rtol=1e-11)
        np.testing.assert_allclose(back.qm, rec.qm, rtol=1e-11)
        assert back.joints == ["j"] and back.input == "torque"
