"""Benchmark: the metaheuristic estimators on 20 000 samples of exo_leg (issue 6's target: PSO, population
100, 200 iterations, ≤ 2 s).

    OPENBLAS_NUM_THREADS=1 python tests/benchmarks/bench_metaheuristics.py [--samples 20000] [--repeat 3]

The data: a random 4-harmonic Fourier motion of exo_leg inside its limits at 1 kHz (20 000 samples =
40 000 torque rows, 10 base parameters), torques from the model plus 1 % Gaussian noise.  Timed:
``Estimator.fit(problem)`` (the box, the swarm, the least-squares reference; building the problem is not
counted), best of ``--repeat`` after one warm-up, for both fitness functions: ``sse`` (½Σr², evaluated in
the compressed nb × nb form: independent of the number of samples) and ``sae`` (Σ|r|: the tall
product W·Xᵀ, 40 000 × 100 per iteration).  Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from pinid import RobotModel
from pinid.data.dataset import Dataset
from pinid.estimators import make_estimator
from pinid.problem.problem import IdentificationProblem
from pinid.progress import choose


def data(model: RobotModel, samples: int, rate: float = 1000.0, seed: int = 0) -> Dataset:
    rng = np.random.default_rng(seed)
    t = np.arange(samples) / rate
    w = 0.2 * np.pi * np.arange(1, 5)
    lo, hi = model.lower, model.upper
    mid, half = 0.5 * (lo + hi), 0.5 * (hi - lo)
    a, b = rng.normal(size=(2, 4)) / np.arange(1, 5), rng.normal(size=(2, 4)) / np.arange(1, 5)
    s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))
    dev, vel, acc = s @ a.T + c @ b.T, (c * w) @ a.T - (s * w) @ b.T, -(s * w**2) @ a.T - (c * w**2) @ b.T
    k = np.minimum(0.85 * half / np.abs(dev).max(axis=0), 0.85 * model.velocity_limit / np.abs(vel).max(axis=0))
    q, dq, ddq = mid + k * dev, k * vel, k * acc
    tau = model.rnea(q, dq, ddq) + model.coulomb * np.sign(dq) + model.viscous * dq
    tau = tau + rng.normal(size=tau.shape) * 0.01 * np.abs(tau).max(axis=0)
    return Dataset(t, q, model.joint_names, dq=dq, ddq=ddq, tau=tau, source="bench")


def quiet(estimator, problem):
    """``estimator`` fitted to ``problem`` without its progress bar (a bar would be timed too)."""
    with choose(False):
        return estimator.fit(problem)


def best_time(fn, repeat: int) -> float:
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--samples", type=int, default=20_000)
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args(argv)
    model = RobotModel.from_urdf("exo_leg")
    problem = IdentificationProblem.from_datasets(model, data(model, args.samples))
    print(
        f"exo_leg, {args.samples} samples, {problem.rows} rows × {problem.nb} base parameters; "
        f"{platform.machine()}, {os.cpu_count()} cores, OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}\n"
    )
    print("| method | fitness | population × iterations | evaluations | best of 3 [s] | target [s] |")
    print("|---|---|---|---|---|---|")
    for name in ("pso", "rls-pso", "woa", "ewoa", "de"):
        for fitness in ("sse", "sae"):
            est = make_estimator(name, population=100, iterations=200, fitness=fitness)
            secs = best_time(lambda: quiet(est, problem), args.repeat)
            target = "2" if name == "pso" else ""
            print(f"| {name} | {fitness} | 100 × 200 | {est.info_['nfev']} | {secs:.3f} | {target} |")
    est = make_estimator("rls")
    secs = best_time(lambda: est.fit(problem), args.repeat)
    print(f"| rls (λ = 1) | — | {problem.rows} rows, one at a time | — | {secs:.3f} | |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
