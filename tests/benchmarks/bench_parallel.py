"""Benchmark: ``pinid compare`` on 1 and N local processes and on a Dask LocalCluster (issue 35).

    python tests/benchmarks/bench_parallel.py [--seeds 8] [--workers 2] [--no-dask] [--repeat 7]

Simulates an exo_leg twin recording and a validation recording (``pinid simulate``), then runs
``pinid compare --seeds N`` with every quick method (the registry's methods that do not simulate the robot)
three ways, in one run of this script: ``--workers 1``, ``--workers N`` and ``--scheduler`` on a Dask
``LocalCluster`` of N single-threaded worker processes.  Prints the wall-clock time of each, the speed-up
over one worker, the machine's load, and whether the three ``comparison.json`` agree to the last digit
(every number except the clock).  With ``--repeat K`` the 1- and N-process runs alternate K times: the
table gives their medians (a shared machine's speed drifts by ±30 % within minutes), then every pair.
Target (issue 35): ≥ 1.7× on 2 workers, the same numbers.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def pinid(*args: str) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "pinid.cli", *args], check=True, capture_output=True, text=True)
    return time.perf_counter() - t0


def numbers(path: Path) -> dict:
    """comparison.json without the clock (the run times, the summary's times, the total)."""
    d = json.loads(path.read_text())
    d.pop("seconds", None)
    d.pop("summary", None)
    for runs in d["runs"].values():
        for r in runs:
            r.pop("seconds", None)
    return d


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=20.0, help="length of the training recording [s]")
    ap.add_argument("--no-dask", action="store_true", help="skip the Dask LocalCluster run")
    ap.add_argument("--repeat", type=int, default=1, help="pairs of 1- and N-process runs, alternating (medians)")
    a = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        train, valid = folder / "train.csv", folder / "valid.csv"
        pinid(
            "simulate",
            "--urdf",
            "exo_leg",
            "--excitation",
            "exo_leg",
            "--seconds",
            str(a.seconds),
            "--seed",
            "1",
            "-o",
            str(train),
        )
        pinid(
            "simulate",
            "--urdf",
            "exo_leg",
            "--excitation",
            "zha2019-1",
            "--seconds",
            "10",
            "--seed",
            "2",
            "-o",
            str(valid),
        )
        common = [
            "compare",
            "--urdf",
            "exo_leg",
            "--data",
            str(train),
            "--validate",
            str(valid),
            "--truth",
            str(train.with_suffix(".truth.json")),
            "--seeds",
            str(a.seeds),
            "--no-figures",
            "--no-progress",
        ]
        load = os.getloadavg()
        one, many = [], []
        for _ in range(a.repeat):  # alternating, so that a drift of the machine's speed touches both alike
            one.append(pinid(*common, "--workers", "1", "-o", str(folder / "one"), "--force"))
            many.append(pinid(*common, "--workers", str(a.workers), "-o", str(folder / "many"), "--force"))
        rows = [("1 process", statistics.median(one), folder / "one")]
        rows.append((f"{a.workers} processes", statistics.median(many), folder / "many"))
        if not a.no_dask:
            from distributed import LocalCluster

            with LocalCluster(
                n_workers=a.workers, threads_per_worker=1, processes=True, dashboard_address=None
            ) as cluster:
                seconds = pinid(*common, "--scheduler", cluster.scheduler_address, "-o", str(folder / "dask"))
            rows.append((f"Dask LocalCluster, {a.workers} workers", seconds, folder / "dask"))
        reference = numbers(rows[0][2] / "comparison.json")
        print(
            f"pinid compare --seeds {a.seeds} (every quick method) on the exo_leg twin ({a.seconds:g} s at the twin's "
            f"rate); load average before: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; {os.cpu_count()} cores\n"
        )
        print("| where | wall [s] | speed-up | same numbers as 1 process |")
        print("|---|---|---|---|")
        for name, seconds, out in rows:
            same = numbers(out / "comparison.json") == reference
            print(f"| {name} | {seconds:.1f} | {rows[0][1] / seconds:.2f}× | {'yes' if same else 'NO'} |")
        if a.repeat > 1:
            pairs = ", ".join(f"{x:.2f}/{y:.2f}" for x, y in zip(one, many))
            print(
                f"\nwall [s] of the {a.repeat} pairs (1 process / {a.workers}): {pairs}; the table gives their medians; "
                f"speed-up of the best runs {min(one) / min(many):.2f}×, of the means {sum(one) / sum(many):.2f}×; "
                f"load average after: {os.getloadavg()[0]:.2f}"
            )


if __name__ == "__main__":
    main()
