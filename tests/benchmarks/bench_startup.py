"""Benchmark: how long a user waits for ``pinid identify`` (issue 17) — wall time from the shell.

    python tests/benchmarks/bench_startup.py                  # this tree
    python tests/benchmarks/bench_startup.py --before /tmp/before   # and an older checkout, same run

Data, made once in a temporary folder with this tree's ``pinid simulate`` (t, q and tau only, so the
default preprocessing — zero-phase filter, Savitzky–Golay derivatives — runs):

* ``ur5`` — the issue's kind of data: a 6-DOF arm, 26 000 samples at 5 kHz (5.2 s), training and
  validation on two excitations designed with ``pinid excite --urdf ur5 --starts 2`` (seeds 3 and 4);
* ``exo_leg`` — 60 s training (preset zha2019-1) and 30 s validation (zha2019-2) at 1 kHz.

Timed per data set, best of ``--repeat`` (default 3), each a fresh interpreter:

* ``import``: ``python -c "import pinid.cli.main"``
* ``identify``: ``pinid identify --methods ols,sdp`` (report and figures on)
* ``identify --no-figures``: report.md without figures (matplotlib never loaded)
* ``identify --no-report``: no report.md and no figures

With ``--before DIR`` every command is also run with ``PYTHONPATH=DIR`` interleaved with this tree's,
so the ratios come from one run on the same (shared, noisy) machine.  Prints a Markdown table with
``nproc``, the CPU model and the load average.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[2]


def machine() -> str:
    cpu = "?"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"nproc {os.cpu_count()}, {cpu}, load {os.getloadavg()[0]:.2f}"


def run(tree: Path, args: list[str], cwd: Path) -> float:
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1")
    env.pop("PYTHONDONTWRITEBYTECODE", None)  # an installed package has its bytecode: the first repeat writes it
    t0 = time.perf_counter()
    subprocess.run(
        [sys.executable, *args], cwd=cwd, env=env, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    return time.perf_counter() - t0


#: The exo_leg twin recordings of this benchmark and bench_same_results: (preset, seconds, seed, file).
TWIN = (("zha2019-1", "60", "1", "train.csv"), ("zha2019-2", "30", "2", "val.csv"))


def twin_recordings(folder: Path) -> None:
    """Write the :data:`TWIN` recordings into ``folder`` with this tree's ``pinid simulate``."""
    for preset, seconds, seed, name in TWIN:
        args = ["simulate", "--urdf", "exo_leg", "--excitation", preset, "--seconds", seconds, "--seed", seed]
        run(HERE, ["-m", "pinid.cli", *args, "-o", name], folder)


#: The 6-DOF arm data: (excitation seed, simulation seed, file); 5.2 s at 5 kHz = 26 000 samples.
ARM = ((3, 1, "ur5_train.csv"), (4, 2, "ur5_val.csv"))


def arm_recordings(folder: Path) -> None:
    """Write the :data:`ARM` recordings (UR5 twin) into ``folder`` with this tree's ``pinid``."""
    for excitation_seed, seed, name in ARM:
        design = f"ur5_excitation_{excitation_seed}.json"
        run(HERE, ["-m", "pinid.cli", "excite", "--urdf", "ur5", "--starts", "2", "--seed", str(excitation_seed),
                   "-o", design], folder)  # fmt: skip
        args = ["simulate", "--urdf", "ur5", "--excitation", design, "--seconds", "5.2", "--sample-rate", "5000"]
        run(HERE, ["-m", "pinid.cli", *args, "--seed", str(seed), "-o", name], folder)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", type=Path, help="an older checkout to time side by side")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    trees = {"this": HERE} | ({"before": a.before.resolve()} if a.before else {})
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        cli = ["-m", "pinid.cli"]
        twin_recordings(d)
        arm_recordings(d)
        data = {"ur5": ("ur5", "ur5_train.csv", "ur5_val.csv"), "exo_leg": ("exo_leg", "train.csv", "val.csv")}
        cases = {"import": ["-c", "import pinid.cli.main"]}
        for label, (urdf, train, val) in data.items():
            ident = [*cli, "identify", "--urdf", urdf, "--data", train, "--validate", val, "--methods", "ols,sdp"]
            ident += ["--force"]
            cases[f"{label}: identify (ols,sdp, report + figures)"] = [*ident, "-o", f"{label}_out"]
            cases[f"{label}: identify --no-figures"] = [*ident, "--no-figures", "-o", f"{label}_nf"]
            cases[f"{label}: identify --no-report"] = [*ident, "--no-report", "-o", f"{label}_nr"]
        best: dict[tuple[str, str], float] = {}
        for _ in range(a.repeat):
            for case, args in cases.items():
                for name, tree in trees.items():
                    if "--no-figures" in args and "--no-figures" not in (tree / "pinid/cli/identify.py").read_text():
                        continue  # the option is new (issue 17): an older checkout lacks it
                    t = run(tree, args, d)
                    best[case, name] = min(best.get((case, name), float("inf")), t)
    print(f"machine: {machine()}\n")
    head = "| case | " + " | ".join(f"{n} [s]" for n in trees) + (" | before/this |" if a.before else " |")
    print(head)
    print("|" + "---|" * (head.count("|") - 1))
    for case in cases:
        row = [f"{best[case, n]:.2f}" if (case, n) in best else "–" for n in trees]
        ratio = (
            (f" | {best[case, 'before'] / best[case, 'this']:.2f}" if (case, "before") in best else " | –")
            if a.before
            else ""
        )
        print(f"| {case} | " + " | ".join(row) + ratio + " |")


if __name__ == "__main__":
    main()
