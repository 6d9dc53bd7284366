"""Benchmark: ``pinid compare`` on 1 and N local processes and on a Dask LocalCluster (issues 35, 45).

    python tests/benchmarks/bench_parallel.py [--seeds 8 32 64] [--workers 2] [--no-dask] [--repeat 7]

Simulates an exo_leg twin recording and a validation recording (``pinid simulate``), then runs
``pinid compare --seeds N`` with every quick method (the registry's methods that do not simulate the robot)
three ways, in one run of this script: ``--workers 1``, ``--workers N`` and ``--scheduler`` on a Dask
``LocalCluster`` of N single-threaded worker processes.  Prints, per seed count, the wall-clock time of each,
the speed-up over one worker and the parallel efficiency (speed-up / workers), the CPU time of the command
and every worker it waited for, the 1-minute load average before each run, and whether the ``comparison.json``
agree to the last digit (every number except the clock).  With ``--repeat K`` the 1- and N-process runs
alternate K times: the table gives their medians (a shared machine's speed drifts by ±30 % within minutes),
then every pair.  Bytecode is written by an untimed first run (an installed package has it; this machine sets
``PYTHONDONTWRITEBYTECODE``, which would add pinid's compilation to every start).  Target (issues 35, 45):
≥ 1.7× on 2 workers with 32 seeds, the same numbers.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def pinid(*args: str) -> tuple[float, float]:
    """Wall and CPU [s] (this command and the workers it waited for) of ``pinid *args``."""
    env = dict(os.environ)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "pinid.cli", *args], check=True, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


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
    ap.add_argument("--seeds", type=int, nargs="+", default=[8])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=20.0, help="length of the training recording [s]")
    ap.add_argument("--no-dask", action="store_true", help="skip the Dask LocalCluster run")
    ap.add_argument("--repeat", type=int, default=1, help="pairs of 1- and N-process runs, alternating (medians)")
    a = ap.parse_args()
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        train, valid = folder / "train.csv", folder / "valid.csv"
        sim = ["simulate", "--urdf", "exo_leg", "--excitation"]
        pinid(*sim, "exo_leg", "--seconds", str(a.seconds), "--seed", "1", "-o", str(train))
        pinid(*sim, "zha2019-1", "--seconds", "10", "--seed", "2", "-o", str(valid))
        print(f"{os.cpu_count()} cores; pinid compare (every quick method) on the exo_leg twin ({a.seconds:g} s)\n")
        for seeds in a.seeds:
            common = ["compare", "--urdf", "exo_leg", "--data", str(train), "--validate", str(valid)]
            common += ["--truth", str(train.with_suffix(".truth.json")), "--seeds", str(seeds)]
            common += ["--no-figures", "--no-progress"]
            pinid(*common, "--workers", "1", "-o", str(folder / "warm"), "--force")  # bytecode, page cache
            one, many = [], []
            for _ in range(a.repeat):  # alternating, so that a drift of the machine's speed touches both alike
                load = os.getloadavg()[0]
                one.append((*pinid(*common, "--workers", "1", "-o", str(folder / "one"), "--force"), load))
                load = os.getloadavg()[0]
                out = str(folder / "many")
                many.append((*pinid(*common, "--workers", str(a.workers), "-o", out, "--force"), load))
            rows = [("1 process", one, folder / "one"), (f"{a.workers} processes", many, folder / "many")]
            if not a.no_dask:
                from distributed import LocalCluster

                with LocalCluster(
                    n_workers=a.workers, threads_per_worker=1, processes=True, dashboard_address=None
                ) as cluster:
                    load = os.getloadavg()[0]
                    run = pinid(*common, "--scheduler", cluster.scheduler_address, "-o", str(folder / "dask"))
                rows.append((f"Dask LocalCluster, {a.workers} workers", [(*run, load)], folder / "dask"))
            reference = numbers(rows[0][2] / "comparison.json")
            t1 = statistics.median(r[0] for r in one)
            print(f"--seeds {seeds}, median of {a.repeat}:\n")
            print("| where | wall [s] | speed-up | efficiency | CPU [s] | load before | same numbers as 1 process |")
            print("|---|---|---|---|---|---|---|")
            for name, runs, out in rows:
                wall = statistics.median(r[0] for r in runs)
                cpu = statistics.median(r[1] for r in runs)
                workers = 1 if name == "1 process" else a.workers
                same = "yes" if numbers(out / "comparison.json") == reference else "NO"
                loads = "–".join(f"{x:.1f}" for x in (min(r[2] for r in runs), max(r[2] for r in runs)))
                print(
                    f"| {name} | {wall:.2f} | {t1 / wall:.2f}× | {t1 / wall / workers:.2f} | {cpu:.2f} | {loads} "
                    f"| {same} |"
                )
            if a.repeat > 1:
                pairs = ", ".join(f"{x[0]:.2f}/{y[0]:.2f}" for x, y in zip(one, many))
                ratios = sorted(x[0] / y[0] for x, y in zip(one, many))
                print(
                    f"\nwall [s] of the {a.repeat} pairs (1 process / {a.workers}): {pairs}; each pair's ratio "
                    f"{', '.join(f'{r:.2f}' for r in ratios)} (median {statistics.median(ratios):.2f}); "
                    f"load average after: {os.getloadavg()[0]:.2f}\n"
                )


if __name__ == "__main__":
    main()
