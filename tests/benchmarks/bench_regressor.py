"""Benchmark: stacking the regressor (issue 2's speed figures).

    python tests/benchmarks/bench_regressor.py

Times ``pinid.model.regressor`` for 100 000 samples of exo_leg and 20 000 samples of the 7-DOF Panda (fingers
locked), best of 3 runs, and prints a Markdown table.  Targets: ≤ 0.5 s and ≤ 1 s on a 2-core machine.
"""

from __future__ import annotations

import platform
import time

import numpy as np

from pinid import JointTerms, RobotModel, regressor

CASES = [("exo_leg", 100_000, 0.5), ("panda", 20_000, 1.0)]


def best_time(fn, repeats: int = 3) -> float:
    """Best wall time of ``repeats`` calls [s]."""
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main() -> None:
    print(f"machine: {platform.processor() or platform.machine()}, python {platform.python_version()}\n")
    print("| robot | samples | regressor shape | best of 3 [s] | target [s] | µs/sample |")
    print("|---|---|---|---|---|---|")
    for name, n, target in CASES:
        model = RobotModel.from_urdf(name)
        q, dq, ddq = model.random_states(n, np.random.default_rng(0))
        shape = regressor(model, q[:2], dq[:2], ddq[:2], JointTerms()).shape[1]
        t = best_time(lambda: regressor(model, q, dq, ddq, JointTerms()))
        print(f"| {name} ({model.nv} DOF) | {n} | {n * model.nv} × {shape} | {t:.3f} | {target} | {t / n * 1e6:.2f} |")


if __name__ == "__main__":
    main()
