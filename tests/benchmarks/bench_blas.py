"""Benchmark: pinid's work with one BLAS thread against the BLAS default (one thread per core).

    python tests/benchmarks/bench_blas.py [--samples 20000] [--repeat 3]

Each workload runs with ``threadpoolctl``'s limit of 1 BLAS thread and of one thread per core, best of
``--repeat`` each;
the ratio is the one to read (the machines are noisy, the ratio within one run is not).  The data are
bench_metaheuristics.py's: a 4-harmonic motion of exo_leg at 1 kHz with 1 % torque noise.  This is why
the CLI runs every command under :func:`pinid.blas.single_threaded_blas`.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_metaheuristics import best_time, data, quiet  # noqa: E402

from pinid import RobotModel  # noqa: E402
from pinid.estimators import make_estimator  # noqa: E402
from pinid.excitation.problem import DesignProblem  # noqa: E402
from pinid.excitation.spec import spec_for  # noqa: E402
from pinid.problem.problem import IdentificationProblem  # noqa: E402
from pinid.model.regressor import regressor  # noqa: E402


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--samples", type=int, default=20_000)
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args(argv)
    model = RobotModel.from_urdf("exo_leg")
    ds = data(model, args.samples)
    problem = IdentificationProblem.from_datasets(model, ds)
    threads = os.cpu_count() or 2
    print(
        f"exo_leg, {args.samples} samples ({problem.rows} rows × {problem.nb} base parameters); "
        f"{platform.machine()}, {threads} cores; BLAS: "
        f"{', '.join(sorted({i.get('internal_api', '?') for i in threadpool_info() if i.get('user_api') == 'blas'}))}\n"
    )
    design = DesignProblem(model, spec_for(model))
    lo, up = design.box()
    X = design.scale_into_limits(lo + np.random.default_rng(0).random((100, design.d)) * (up - lo))
    workloads = {
        "excitation: 100 criterion values + gradients": lambda: [design.objective_and_gradient(x) for x in X],
        "excitation: one swarm of 100 criterion values": lambda: design.evaluate(X),
        "regressor (Pinocchio, no BLAS)": lambda: regressor(model, ds.q, ds.dq, ds.ddq),
        "identification problem (QR)": lambda: IdentificationProblem.from_datasets(model, ds),
        "ols": lambda: make_estimator("ols").fit(problem),
        "sdp (LMI, Clarabel)": lambda: make_estimator("sdp").fit(problem),
        "pso, sse, 100 × 200": lambda: quiet(make_estimator("pso"), problem),
        "pso, sae, 100 × 200": lambda: quiet(make_estimator("pso", fitness="sae"), problem),
        "rls": lambda: make_estimator("rls").fit(problem),
    }
    print(f"| workload | 1 thread [s] | {threads} threads [s] | {threads} threads / 1 thread |")
    print("|---|---|---|---|")
    for name, fn in workloads.items():
        with threadpool_limits(1, user_api="blas"):
            one = best_time(fn, args.repeat)
        with threadpool_limits(threads, user_api="blas"):
            many = best_time(fn, args.repeat)
        print(f"| {name} | {one:.3f} | {many:.3f} | {many / one:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
