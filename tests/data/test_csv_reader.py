"""The CSV reader (pinid/data/csv_reader.py): long lines, wide files in linear time."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import pytest

from pinid.data.formats import read_recording
from pinid.errors import DataError

ROOT = Path(__file__).resolve().parents[2]


def _wide_csv(path: Path, columns: int, rows: int = 10) -> None:
    sys.path.insert(0, str(ROOT / "tests" / "benchmarks"))
    try:
        from bench_wide_csv import write
    finally:
        sys.path.pop(0)
    write(path, columns, rows)


def test_long_lines_are_not_cut_short(tmp_path):
    """Case 24: lines over 8 KB (5005 columns) are read, and a really cut last line is still refused."""
    path = tmp_path / "w.csv"
    _wide_csv(path, 5005)
    assert len(path.read_text().splitlines()[1]) > 8192
    ds = read_recording(path, model="exo_leg")
    assert len(ds.t) == 10
    assert ds.meta["ignored_columns"][:2] == ["x0", "x1"]
    text = path.read_text()
    path.write_text(text[: -len(text.splitlines()[-1]) // 2 - 1] + "\n")  # the last line cut in its middle
    with pytest.raises(DataError, match="cut short"):
        read_recording(path, model="exo_leg")


def test_wide_csv_reads_in_linear_time(tmp_path):
    """Case 22: 40 000 columns read within a few times the time of 10 000 (was quadratic: 61 s)."""
    times = {}
    for n in (10_000, 40_000):
        path = tmp_path / f"w{n}.csv"
        _wide_csv(path, n)
        read_recording(path, model="exo_leg")  # warm
        t0 = time.perf_counter()
        read_recording(path, model="exo_leg")
        times[n] = time.perf_counter() - t0
    assert times[40_000] < 2.0, times
    assert times[40_000] < 12 * times[10_000] + 0.05, times  # linear: 4×; quadratic would be 16×
