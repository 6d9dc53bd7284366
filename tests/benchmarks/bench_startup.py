"""Benchmark: how long a user waits for ``pinid identify`` (issue 17) — wall time from the shell.

    python tests/benchmarks/bench_startup.py                  # this tree
    python tests/benchmarks/bench_startup.py --before /tmp/before   # and an older checkout, same run

Data: the exo_leg twin (``pinid simulate``, preset zha2019-1, 60 s training + zha2019-2, 30 s validation
at 1 kHz; t, q and tau only, so the default preprocessing — zero-phase filter, Savitzky–Golay
derivatives — runs), made once in a temporary folder.  Timed, best of ``--repeat`` (default 3), each a
fresh interpreter:

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
        ident = [
            *cli,
            "identify",
            "--urdf",
            "exo_leg",
            "--data",
            "train.csv",
            "--validate",
            "val.csv",
            "--methods",
            "ols,sdp",
            "--force",
        ]
        cases = {
            "import": ["-c", "import pinid.cli.main"],
            "identify (ols,sdp, report + figures)": [*ident, "-o", "out"],
            "identify --no-figures": [*ident, "--no-figures", "-o", "out_nf"],
            "identify --no-report": [*ident, "--no-report", "-o", "out_nr"],
        }
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
