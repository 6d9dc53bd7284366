"""Benchmark: the controller API's batch calls (issue 15), per sample, on a 2-DOF leg and a 7-DOF arm.

    python tests/benchmarks/bench_identified_model.py [--samples N]

For exo_leg and Panda (fingers locked), an ``IdentifiedModel`` with Coulomb + viscous friction and
armature: µs per sample of each dynamics method called on an (N, nv) batch, next to the same method
called sample by sample, and next to the floor — a bare Python loop over Pinocchio's C++ call
(``pin.rnea`` etc.) with nothing else.  Best of 3, one process, so the ratios are what to read.
"""

from __future__ import annotations

import argparse
import platform

import numpy as np
import pinocchio as pin

from pinid import TermSelection, RobotModel, standard_parameters
from pinid.identification.identified import IdentifiedModel

from bench_regressor import best_time  # noqa: E402 - the script's own folder is on the path

TERMS = TermSelection(coulomb=True, viscous=True, armature=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=2000)
    n = ap.parse_args().samples
    print(
        f"machine: {platform.processor() or platform.machine()}, python {platform.python_version()}, "
        f"pinocchio {pin.__version__}, {n} samples\n"
    )
    print("| robot | method | batch [µs/sample] | one by one [µs/sample] | C++ floor [µs/sample] |")
    print("|---|---|---|---|---|")
    for name in ("exo_leg", "panda"):
        robot = RobotModel.from_urdf(name)
        theta = standard_parameters(robot, TERMS)
        theta[10 * robot.nv :] = 0.1
        m = IdentifiedModel(robot, TERMS, theta)
        q, dq, ddq = robot.random_states(n, np.random.default_rng(0))
        tau = m.inverse_dynamics(q, dq, ddq)
        pm, pd = m.pin_model, m.pin_data
        floors = {
            "inverse_dynamics": lambda: [pin.rnea(pm, pd, a, b, c) for a, b, c in zip(q, dq, ddq)],
            "mass_matrix": lambda: [pin.crba(pm, pd, a) for a in q],
            "coriolis": lambda: [pin.computeCoriolisMatrix(pm, pd, a, b) for a, b in zip(q, dq)],
            "gravity": lambda: [pin.computeGeneralizedGravity(pm, pd, a) for a in q],
            "forward_dynamics": lambda: [pin.aba(pm, pd, a, b, c) for a, b, c in zip(q, dq, tau)],
            "derivatives": lambda: [pin.computeRNEADerivatives(pm, pd, a, b, c) for a, b, c in zip(q, dq, ddq)],
        }
        args = {
            "inverse_dynamics": (q, dq, ddq),
            "mass_matrix": (q,),
            "coriolis": (q, dq),
            "gravity": (q,),
            "forward_dynamics": (q, dq, tau),
            "derivatives": (q, dq, ddq),
        }
        for method, floor in floors.items():
            f, a = getattr(m, method), args[method]
            batch = best_time(lambda: f(*a))
            single = best_time(lambda: [f(*x) for x in zip(*a)])
            print(
                f"| {name} ({robot.nv} DOF) | `{method}` | {batch / n * 1e6:.1f} | {single / n * 1e6:.1f} | "
                f"{best_time(floor) / n * 1e6:.1f} |"
            )


if __name__ == "__main__":
    main()
