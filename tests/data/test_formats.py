"""Recording files written and read (pinid/data/formats.py)."""

from __future__ import annotations

import numpy as np

from pinid.data.dataset import Dataset
from pinid.data.formats import read_recording, time_digits, write_recording


def test_epoch_time_written_exactly(tmp_path):
    """Item 8: t = 1.7e9 s in 1 ms steps is written with every digit and read back exactly."""
    t = 1.7e9 + np.arange(3000) * 1e-3
    q = np.c_[np.sin(t - 1.7e9), np.cos(t - 1.7e9)]
    path = write_recording(tmp_path / "epoch.csv", Dataset(t, q, ["hip", "knee"], tau=2 * q))
    back = read_recording(path)
    np.testing.assert_array_equal(back.t, t)
    np.testing.assert_array_equal(back.q, np.asarray([[float(f"{v:.12g}") for v in row] for row in q]))
    assert time_digits(np.arange(1500) / 500.0, 12) == 12  # ordinary time stamps: written as before
