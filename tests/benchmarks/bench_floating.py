"""Benchmark: the floating base (issue 27).

    python tests/benchmarks/bench_floating.py [--samples 20000] [--seconds 60] [--repeat 3]

1. Regressor stacking with a free flyer: :func:`pinid.model.regressor.regressor` of the floating model on
   ``model.full_state(...)`` (checks, state assembly, terms fc, fv) against the bare Pinocchio loop (``computeJointTorqueRegressor`` on pre-assembled
   configuration, velocity and acceleration arrays, written into a preallocated array) on the same random
   states of exo_lower_body (8 joints, 9 bodies) — target ≤ 1.3×.
2. Identification with contacts of ``--seconds`` at 1 kHz of the 8-joint exoskeleton walking (the gait twin,
   two force plates): (a) from the prepared samples, stacking (6 + 8 rows per sample, contact wrenches' Jᵀf
   on the right) + OLS; the same + SDP; (b) the whole :func:`pinid.identification.run.identify` from the CSV file (read,
   filter, differentiate, stack, OLS) — target ≤ 3 s.
Best of ``--repeat``; the machine's load is printed (2 cores shared).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinid import RobotModel
from pinid.identification.study import Study
from pinid.data.formats import write_recording
from pinid.estimators import make_estimator
from pinid.identification.run import identify
from pinid.problem.floating import floating_problem
from pinid.model.floating import random_floating_states
from pinid.model.regressor import regressor
from pinid.model.terms import TermSelection
from pinid.simulation.floating_twin import Noise, simulate_gait


CPU: list[float] = []  # the process's CPU time of each best() call (less sensitive to a shared machine's load)


def best(f, repeat: int) -> float:
    """Best wall time [s] of ``repeat`` calls; the best CPU time goes to CPU."""
    times, cpu = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        f()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    CPU.append(min(cpu))
    return min(times)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--samples", type=int, default=20_000)
    p.add_argument("--seconds", type=float, default=60.0)
    p.add_argument("--repeat", type=int, default=3)
    args = p.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    model = RobotModel.from_urdf("exo_lower_body", base="floating")
    terms = TermSelection.from_names("fc,fv")
    states = random_floating_states(model, args.samples, np.random.default_rng(0))
    m, d = model.ff_model, model.ff_model.createData()
    Q, V, A = model.full_state(*states)
    rows = 6 + model.nv

    def bare():
        out = np.empty((args.samples, rows, 10 * (model.nv + 1)))
        for k in range(args.samples):
            out[k] = pin.computeJointTorqueRegressor(m, d, Q[k], V[k], A[k])
        return out

    t_bare = best(bare, args.repeat)
    t_none = best(lambda: regressor(model, *model.full_state(*states), TermSelection.from_names("none")), args.repeat)
    t_terms = best(lambda: regressor(model, *model.full_state(*states), terms), args.repeat)
    print(f"\n1. regressor stacking, exo_lower_body floating, {args.samples} samples ({args.samples * rows} rows)")
    c_bare, c_none, c_terms = CPU[-3:]
    print(
        f"   bare Pinocchio loop            {t_bare:.3f} s wall, {c_bare:.3f} s CPU ({1e6 * c_bare / args.samples:.2f} µs/sample)"
    )
    print(
        f"   regressor, floating, no terms {t_none:.3f} s wall, {c_none:.3f} s CPU; ratio {c_none / c_bare:.2f} CPU (target ≤ 1.3)"
    )
    print(
        f"   regressor, floating, fc fv    {t_terms:.3f} s wall, {c_terms:.3f} s CPU; ratio {c_terms / c_bare:.2f} CPU"
    )

    t0 = time.perf_counter()
    run = simulate_gait(model, seconds=args.seconds, rate=1000.0, noise=Noise(1e-5, 0.2, 2.0, 0.2))
    print(
        f"\n2. gait twin {args.seconds:g} s at 1 kHz ({run.exact.n} samples) simulated in {time.perf_counter() - t0:.2f} s"
    )
    s = run.exact

    def ols():
        problem = floating_problem(model, s, terms=terms)
        return make_estimator("ols").fit(problem)

    def sdp():
        problem = floating_problem(model, s, terms=terms)
        return make_estimator("sdp").fit(problem)

    t_ols = best(ols, args.repeat)
    t_sdp = best(sdp, args.repeat)
    print(f"   stack + OLS (prepared samples)          {t_ols:.2f} s wall, {CPU[-2]:.2f} s CPU (target ≤ 3)")
    print(f"   stack + SDP (prepared samples)          {t_sdp:.2f} s wall, {CPU[-1]:.2f} s CPU")
    with tempfile.TemporaryDirectory() as tmp:
        path = write_recording(Path(tmp) / "gait.csv", run.recording)
        t_file = best(lambda: identify(Study(model, path, terms=terms), methods=["ols"]), args.repeat)
        t_file2 = best(lambda: identify(Study(model, path, terms=terms), methods=["ols", "sdp"]), args.repeat)
    print(
        f"   identify (floating) from the CSV, ols     {t_file:.2f} s wall, {CPU[-2]:.2f} s CPU (read, filter, differentiate, stack, fit)"
    )
    print(f"   identify (floating) from the CSV, ols,sdp {t_file2:.2f} s wall, {CPU[-1]:.2f} s CPU")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
