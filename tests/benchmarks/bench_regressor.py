"""Benchmark: stacking the regressor (issue 2's speed figures).

    python tests/benchmarks/bench_regressor.py

Times ``pinid.model.regressor`` for 100 000 samples of exo_leg, 26 000 of the 6-DOF UR5 and 20 000 of the
7-DOF Panda (fingers locked), best of 3 runs, and prints a Markdown table.  Targets: ≤ 0.5 s and ≤ 1 s on a
2-core machine.  The *floor* (issue 17) is the limit of any Python caller: a bare loop of Pinocchio's
``computeJointTorqueRegressor`` on the same states, one reused ``pin.Data``, results thrown away.
"""

from __future__ import annotations

import platform
import time

import numpy as np
import pinocchio as pin

from pinid import TermSelection, RobotModel, regressor

CASES = [("exo_leg", 100_000, 0.5), ("ur5", 26_000, None), ("panda", 20_000, 1.0)]


def best_time(fn, repeats: int = 3) -> float:
    """Best wall time of ``repeats`` calls [s]."""
    best = np.inf
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def bare_loop(model: RobotModel, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> None:
    """Pinocchio's regressor for every sample and nothing else: what a Python caller cannot beat."""
    m, d = model.pin_model, model.pin_model.createData()
    compute = pin.computeJointTorqueRegressor
    for k in range(len(q)):
        compute(m, d, q[k], dq[k], ddq[k])


def main() -> None:
    print(f"machine: {platform.processor() or platform.machine()}, python {platform.python_version()}\n")
    print("| robot | samples | regressor shape | best of 3 [s] | target [s] | µs/sample | floor µs/sample | / floor |")
    print("|---|---|---|---|---|---|---|---|")
    for name, n, target in CASES:
        model = RobotModel.from_urdf(name)
        q, dq, ddq = model.random_states(n, np.random.default_rng(0))
        shape = regressor(model, q[:2], dq[:2], ddq[:2], TermSelection()).shape[1]
        t = best_time(lambda: regressor(model, q, dq, ddq, TermSelection()))
        floor = best_time(lambda: bare_loop(model, q, dq, ddq))
        print(
            f"| {name} ({model.nv} DOF) | {n} | {n * model.nv} × {shape} | {t:.3f} | {target or '–'} | "
            f"{t / n * 1e6:.2f} | {floor / n * 1e6:.2f} | {t / floor:.2f} |"
        )


if __name__ == "__main__":
    main()
