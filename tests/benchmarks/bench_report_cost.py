"""Benchmark: what the figures and report cost against the numbers (issue 45, part 1).

    python tests/benchmarks/bench_report_cost.py [--before OLD_CHECKOUT] [--repeat 3] [--kuka ../shared/data/kuka_med7]

Times ``pinid identify --methods ols,sdp`` with figures and report (the default) and with ``--no-figures``,
each a fresh interpreter, on

* ``ur5``: a 6-DOF twin recording at 5 kHz, 9 s = 45 000 samples (the issue's kind of data), validated on a
  second excitation (both made once with this tree's ``pinid excite --starts 2`` and ``pinid simulate``);
* ``kuka``: the KUKA LBR Med 7 ``mext.csv`` (100 Hz, 7 joints), first 70 % → last 30 %, ``--terms
  fc,fv,offset`` (docs/identification.md), when ``--kuka`` names its folder.

A warm-up run per tree and data set first (not timed; it writes the bytecode, as an installed package has it).
Paired runs: each repeat runs, per data set, this tree with and without figures and (``--before``) the old
tree with and without figures, one after the other, so that a ratio compares runs made seconds apart on the
same (shared) machine.  Prints, per run, wall and CPU (the process and every worker it waited for) and the
1-minute load average before it; then per data set and tree the medians and the ratio with/without figures
(target ≤ 1.5), and the ratio of each pair's median.  Also checks that the identification.json numbers of the
two trees agree (every number but the clock).
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

HERE = Path(__file__).resolve().parents[2]


def load() -> float:
    return os.getloadavg()[0]


def run(tree: Path, args: list[str], cwd: Path) -> tuple[float, float]:
    """Wall and CPU [s] of ``python -m pinid.cli *args`` with ``tree`` first on the path."""
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # an installed package has its bytecode: the warm-up run writes it
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "pinid.cli", *args], cwd=cwd, env=env, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def numbers(path: Path):
    """identification.json without the clock and paths (what must not change)."""

    def strip(x):
        if isinstance(x, dict):
            return {k: strip(v) for k, v in x.items() if not k.endswith("seconds") and k not in ("created", "pinid")}
        if isinstance(x, list):
            return [strip(v) for v in x]
        return x

    return strip(json.loads(path.read_text()))


def ur5_recordings(folder: Path) -> tuple[str, str]:
    for excitation_seed, seed, name in ((3, 1, "ur5_train.csv"), (4, 2, "ur5_val.csv")):
        design = f"ur5_excitation_{excitation_seed}.json"
        run(HERE, ["excite", "--urdf", "ur5", "--starts", "2", "--seed", str(excitation_seed), "-o", design], folder)
        sim = ["simulate", "--urdf", "ur5", "--excitation", design, "--seconds", "9", "--sample-rate", "5000"]
        run(HERE, [*sim, "--seed", str(seed), "-o", name], folder)
    return "ur5_train.csv", "ur5_val.csv"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", type=Path, help="an older checkout, timed in the same pairs")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--kuka", type=Path, help="the folder of the KUKA LBR Med 7 recordings (mext.csv, robot.urdf)")
    ap.add_argument("--data", type=Path, help="a folder to keep the made recordings in (made once, then reused)")
    a = ap.parse_args()
    trees = {"this": HERE} | ({"before": a.before.resolve()} if a.before else {})
    with tempfile.TemporaryDirectory() as tmp:
        d = a.data.resolve() if a.data else Path(tmp)
        d.mkdir(parents=True, exist_ok=True)
        if not (d / "ur5_val.csv").exists():
            ur5_recordings(d)
        cases = {"ur5 5 kHz, 45 000 samples": ["--urdf", "ur5", "--data", "ur5_train.csv", "--validate", "ur5_val.csv"]}
        if a.kuka:
            k = a.kuka.resolve()
            (d / "kuka70.toml").write_text(
                f'[[recording]]\nfile = "{k / "mext.csv"}"\nrole = "train"\nrows = [0, 7004]\n'
                f'[[recording]]\nfile = "{k / "mext.csv"}"\nrole = "validate"\nrows = [7004]\n'
            )
            cases["KUKA Med7 mext.csv, fc,fv,offset"] = [
                *("--urdf", str(k / "robot.urdf"), "--manifest", "kuka70.toml", "--terms", "fc,fv,offset"),
            ]
        for tree in trees.values():  # warm-up, not timed: bytecode written, files in the page cache
            for args in cases.values():
                run(tree, ["identify", *args, "--methods", "ols,sdp", "--force", "-o", "out_warm_up"], d)
        times: dict[tuple[str, str, str], list[tuple[float, float, float]]] = {}
        print(f"nproc {os.cpu_count()}; each line: case, tree, figures?, wall [s], CPU [s], load before\n")
        for r in range(a.repeat):
            for case, args in cases.items():
                for name, tree in trees.items():
                    for fig in ("figures", "no figures"):
                        out = f"out_{name}_{fig.replace(' ', '_')}_{list(cases).index(case)}"
                        extra = ["--no-figures"] if fig == "no figures" else []
                        cmd = ["identify", *args, "--methods", "ols,sdp", "--force", *extra, "-o", out]
                        ld = load()
                        wall, cpu = run(tree, cmd, d)
                        times.setdefault((case, name, fig), []).append((wall, cpu, ld))
                        print(f"{r} | {case} | {name} | {fig} | {wall:.2f} | {cpu:.2f} | {ld:.2f}", flush=True)
            if r == 0 and a.before:
                for i, case in enumerate(cases):
                    same = numbers(d / f"out_this_figures_{i}/identification.json") == numbers(
                        d / f"out_before_figures_{i}/identification.json"
                    )
                    print(f"{case}: identification.json numbers identical to the old tree's: {same}")
        print(f"\nmedians of {a.repeat} (load {load():.2f} at the end)\n")
        print(
            "| case | tree | with figures: wall / CPU [s] | without: wall / CPU [s] | with / without (wall) | (CPU) |"
        )
        print("|---|---|---|---|---|---|")
        for case in cases:
            for name in trees:
                w = times[case, name, "figures"]
                n = times[case, name, "no figures"]
                mw, mc = statistics.median(x[0] for x in w), statistics.median(x[1] for x in w)
                nw, nc = statistics.median(x[0] for x in n), statistics.median(x[1] for x in n)
                pairs = [x[0] / y[0] for x, y in zip(w, n)]
                print(
                    f"| {case} | {name} | {mw:.2f} / {mc:.2f} | {nw:.2f} / {nc:.2f} | **{mw / nw:.2f}** "
                    f"(pairs {', '.join(f'{p:.2f}' for p in pairs)}) | {mc / nc:.2f} |"
                )


if __name__ == "__main__":
    main()
