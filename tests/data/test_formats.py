"""Recording files written and read (pinid/data/formats.py); a duplicate column is named."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli

from pinid.data.dataset import Dataset
from pinid.data.formats import read_recording, time_digits, write_recording
from pinid.errors import DataError


def test_epoch_time_written_exactly(tmp_path):
    """Item 8: t = 1.7e9 s in 1 ms steps is written with every digit and read back exactly."""
    t = 1.7e9 + np.arange(3000) * 1e-3
    q = np.c_[np.sin(t - 1.7e9), np.cos(t - 1.7e9)]
    path = write_recording(tmp_path / "epoch.csv", Dataset(t, q, ["hip", "knee"], tau=2 * q))
    back = read_recording(path)
    np.testing.assert_array_equal(back.t, t)
    np.testing.assert_array_equal(back.q, np.asarray([[float(f"{v:.12g}") for v in row] for row in q]))
    assert time_digits(np.arange(1500) / 500.0, 12) == 12  # ordinary time stamps: written as before


def _identify(tmp_path: Path, *args: str):
    out = tmp_path / "results"
    return run_cli("identify", "--urdf", "exo_leg", "--methods", "ols", "--no-report", "-o", str(out), *args), out


def test_duplicate_column_is_named(tmp_path, rec):
    lines = rec.read_text().splitlines()
    lines = [ln + "," + ln.split(",")[1] for ln in lines]  # a second q_hip
    bad = tmp_path / "dup.csv"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match="column 'q_hip' appears 2 times"):
        read_recording(bad)
    proc, out = _identify(tmp_path, "--data", str(bad))
    assert_clean_error(proc, "column 'q_hip' appears 2 times in the header")
    assert not out.exists()
