"""Benchmark: how long `pinid demo` takes from the shell, step by step (issue 17: target ≤ 30 s).

    python tests/benchmarks/bench_demo.py                         # this tree
    python tests/benchmarks/bench_demo.py --before /tmp/before    # and an older checkout, one after the other
    python tests/benchmarks/bench_demo.py --before /tmp/before --repeat 3   # alternating, the fastest of 3 each

Runs ``pinid demo -o out`` in an empty folder (fresh process, imports included), reads its output as it
streams and prints the wall time of each of its five steps and of the whole command.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[2]


def demo(tree: Path) -> tuple[float, list[tuple[str, float]]]:
    """(total wall [s], [(step title, wall [s])]) of ``pinid demo`` with ``tree`` on the path."""
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1", PYTHONUNBUFFERED="1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # an installed package has its bytecode (written by the first run)
    steps: list[tuple[str, float]] = []
    with tempfile.TemporaryDirectory() as tmp:  # not the tree: `python -m` puts the cwd first on the path
        t0 = time.perf_counter()
        proc = subprocess.Popen(
            [sys.executable, "-m", "pinid.cli", "demo", "-o", "out"],
            cwd=tmp,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        last, title = t0, "start-up (imports)"
        for line in proc.stdout:
            if line.startswith("[") and "/" in line[:6]:
                now = time.perf_counter()
                steps.append((title, now - last))
                last, title = now, line.split(": pinid ", 1)[0].strip()  # "[i/n] title: pinid …" or "[i/n] title"
        proc.wait()
        end = time.perf_counter()
        steps.append((title, end - last))
    if proc.returncode:
        raise SystemExit(f"pinid demo failed with {tree}")
    return end - t0, steps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", type=Path, help="an older checkout to time next to this tree")
    ap.add_argument("--repeat", type=int, default=1, help="runs per tree, the trees alternating; the fastest is shown")
    a = ap.parse_args()
    print(
        f"machine: {platform.machine()}, nproc {os.cpu_count()}, python {platform.python_version()}, "
        f"load {os.getloadavg()[0]:.2f}"
    )
    trees = ([("before", a.before.resolve())] if a.before else []) + [("this", HERE)]
    runs: dict[str, list[tuple[float, list[tuple[str, float]]]]] = {name: [] for name, _ in trees}
    for _ in range(a.repeat):
        for name, tree in trees:
            runs[name].append(demo(tree))
    for name, _ in trees:
        total, steps = min(runs[name], key=lambda r: r[0])
        others = ", ".join(f"{t:.1f}" for t, _ in runs[name])
        print(f"\n{name}: `pinid demo` {total:.1f} s wall (runs: {others} s)\n\n| step | wall [s] |\n|---|---|")
        for title, seconds in steps:
            print(f"| {title} | {seconds:.1f} |")
    print(f"\nload after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
