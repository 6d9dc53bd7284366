"""Benchmark: reading a wide CSV (many columns, few rows) is linear in its width (issue 25 case 22).

    python tests/benchmarks/bench_wide_csv.py                 # 10 000, 20 000, 40 000, 80 000 columns × 10 rows
    python tests/benchmarks/bench_wide_csv.py --columns 40000 --rows 10

Writes an exo_leg recording (t, q_hip, q_knee, tau_hip, tau_knee) padded with extra columns x0, x1, …,
reads it with ``pinid.data.formats.read_recording`` and prints the seconds per width, and the ratio of
the time per column at the widest to that at the narrowest (≈ 1 when linear).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from pinid.data.formats import read_recording


def write(path: Path, columns: int, rows: int) -> None:
    extra = columns - 5
    header = ",".join(["t", "q_hip", "q_knee", "tau_hip", "tau_knee"] + [f"x{i}" for i in range(extra)])
    lines = [header]
    for k in range(rows):
        t = k / 100.0
        lines.append(",".join([f"{t:g}", f"{0.6 + 0.1 * np.sin(t):.6f}", "-0.9", "5", "1"] + ["0"] * extra))
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--columns", type=int, nargs="*", default=[10_000, 20_000, 40_000, 80_000])
    ap.add_argument("--rows", type=int, default=10)
    args = ap.parse_args()
    per_column = []
    with tempfile.TemporaryDirectory() as tmp:
        warm = Path(tmp) / "warm.csv"  # the first read loads the model and the readers: not timed
        write(warm, 10, args.rows)
        read_recording(warm, model="exo_leg")
        for n in args.columns:
            path = Path(tmp) / f"wide_{n}.csv"
            write(path, n, args.rows)
            t0 = time.perf_counter()
            ds = read_recording(path, model="exo_leg")
            dt = time.perf_counter() - t0
            per_column.append(dt / n)
            print(
                f"{n:>7} columns × {args.rows} rows: {dt:7.3f} s  ({1e6 * dt / n:.2f} µs per column, {len(ds.t)} rows)"
            )
    if len(per_column) > 1:
        print(f"time per column, widest / narrowest: {per_column[-1] / per_column[0]:.2f} (1 = linear)")


if __name__ == "__main__":
    main()
