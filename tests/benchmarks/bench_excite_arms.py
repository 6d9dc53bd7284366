"""Benchmark: `pinid excite` on the 2-DOF leg and on 6- and 7-DOF arms (issue 17).

    python tests/benchmarks/bench_excite_arms.py                      # this tree: exo_leg, ur5, panda defaults
    python tests/benchmarks/bench_excite_arms.py --before /tmp/before # each default design with both trees
    python tests/benchmarks/bench_excite_arms.py --floating           # and the floating lower body

Each case is one `pinid excite` command line run from the shell (a fresh process, imports included) in an
empty folder; the script prints the wall time, the command's own design time and the condition number it
reports.  With ``--before DIR`` (a checkout of an older pinid) every case is run with both trees, one
right after the other, so that their ratio comes from the same machine state; the load (1-minute
average) is printed before each pair.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def excite(tree: Path, args: list[str]) -> tuple[float, float, float, float, int]:
    """(wall [s], design time printed [s], condition number, CPU [s] of the command and its worker processes,
    criterion evaluations) of ``pinid excite ARGS`` with ``tree`` on the path."""
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg")
    with tempfile.TemporaryDirectory() as tmp:  # not the tree: `python -m` would put the cwd first on the path
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t = time.perf_counter()
        proc = subprocess.run(
            [sys.executable, "-m", "pinid.cli", "excite", *args, "-o", "design.json"],
            cwd=tmp,
            env=env,
            capture_output=True,
            text=True,
        )
        wall = time.perf_counter() - t
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
        nfev = json.loads((Path(tmp) / "design.json").read_text()).get("nfev", -1) if not proc.returncode else -1
    if proc.returncode:
        raise SystemExit(f"pinid excite {' '.join(args)} failed ({tree}):\n{proc.stderr}")
    m = re.search(r"condition number ([0-9.]+) in ([0-9.]+) s", proc.stdout)
    return wall, float(m.group(2)), float(m.group(1)), cpu, nfev


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", type=Path, help="checkout of an older pinid to run every case with too")
    ap.add_argument("--floating", action="store_true", help="also the floating lower body (exo_lower_body)")
    args = ap.parse_args()
    print(
        f"machine: {platform.machine()}, nproc {os.cpu_count()}, {platform.processor() or '?'}, "
        f"python {platform.python_version()}, load {os.getloadavg()[0]:.2f}"
    )
    print(
        "\n| tree | command | load | wall [s] | CPU [s] | design [s] | evaluations | condition number |"
        "\n|---|---|---|---|---|---|---|---|"
    )
    cases = [["--urdf", "exo_leg"], ["--urdf", "ur5"], ["--urdf", "panda"]]
    if args.floating:
        cases.append(["--urdf", "exo_lower_body", "--base", "floating"])
    for argv in cases:
        for tree in ([args.before] if args.before else []) + [ROOT]:
            load = os.getloadavg()[0]
            wall, design, cond, cpu, nfev = excite(tree, argv)
            name = "before" if tree != ROOT else "this"
            print(
                f"| {name} | `pinid excite {' '.join(argv)}` | {load:.2f} | {wall:.1f} | {cpu:.1f} | {design:.1f} "
                f"| {nfev} | {cond:.4f} |",
                flush=True,
            )
    print(f"\nload after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
