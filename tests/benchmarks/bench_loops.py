"""Benchmark: the Python loops of the twin and of the closed loops, per call (issue 35: what ``pinid demo``'s
simulate and track steps spend their CPU on).

    python tests/benchmarks/bench_loops.py                          # this tree
    python tests/benchmarks/bench_loops.py --before /tmp/before     # and an older checkout, alternating

In a fresh interpreter per tree and repeat (``PYTHONPATH`` the tree), best of ``--repeat`` (default 5):

* ``Plant.step`` [µs a call] of exo_leg and UR5 with their URDF friction, at random states (half of them
  near zero velocity, where friction is integrated implicitly);
* one call of seed 001's backstepping and of computed torque on exo_leg's URDF model [µs];
* ``track`` of exo_leg for 6 s (6 000 controller calls, 24 000 plant steps) and the twin's ``simulate`` of
  10 s (20 000 plant steps, 10 000 controller updates) [s].

CPU time (``time.process_time``) of a warm loop: what the trees' code costs, not the machine's drift.
Prints a Markdown table with the machine's load.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[2]

MEASURE = r"""
import json, time, warnings
import numpy as np
import pinid
print(pinid.__file__)
warnings.simplefilter("ignore")
from pinid.model.robot import RobotModel
from pinid.control.controllers import Backstepping, ComputedTorque, Tracking, load_controller_model, track
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.twin import simulate
try:
    from pinid.simulation.plant import Plant
except ImportError:  # before the plant had its own module
    from pinid.simulation.twin import Plant

def cpu(f, n):
    f()
    t0 = time.process_time()
    for _ in range(n):
        f()
    return (time.process_time() - t0) / n

out = {}
rng = np.random.default_rng(0)
for name in ("exo_leg", "ur5"):
    robot = RobotModel.from_urdf(name)
    plant = Plant(robot, robot.coulomb, robot.viscous, 0.01)
    states = [(rng.uniform(-0.5, 0.5, robot.nv), rng.uniform(-1, 1, robot.nv) * (1e-3 if k % 2 else 1.0),
               rng.uniform(-5, 5, robot.nv)) for k in range(200)]
    out[f"Plant.step, {name} [µs]"] = 1e6 * cpu(lambda: [plant.step(q, v, tau, 5e-4) for q, v, tau in states], 25) / 200
leg = RobotModel.from_urdf("exo_leg")
model = load_controller_model("nominal", leg)
q, dq = np.array([0.6, -0.9]), np.array([0.3, -0.2])
for label, make in (("backstepping", Backstepping), ("computed torque", ComputedTorque)):
    c = make(model)
    out[f"{label}, one call [µs]"] = 1e6 * cpu(lambda: [c(0.0, q, dq, q, dq, dq) for _ in range(200)], 25) / 200
reference = load_trajectory("zha2019-1", leg)
out["track exo_leg 6 s, computed torque [s]"] = cpu(
    lambda: track(leg, ComputedTorque(model), reference, Tracking(6.0, position_noise=2e-5)), 2)
out["simulate exo_leg 10 s [s]"] = cpu(lambda: simulate(leg, reference, seconds=10, seed=1), 2)
print(json.dumps(out))
"""


def measure(tree: Path) -> dict[str, float]:
    env = dict(os.environ, PYTHONPATH=str(tree), OPENBLAS_NUM_THREADS="1", MPLBACKEND="Agg")
    # not from the repository: ``python -c`` puts the working folder first on the path, before PYTHONPATH's tree
    run = subprocess.run(
        [sys.executable, "-c", MEASURE], env=env, cwd=tempfile.gettempdir(), check=True, capture_output=True, text=True
    )
    if not run.stdout.startswith(str(tree)):
        raise SystemExit(f"measured {run.stdout.splitlines()[0]}, expected the tree {tree}")
    return json.loads(run.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", type=Path, help="an older checkout to time alternately")
    ap.add_argument("--repeat", type=int, default=5)
    a = ap.parse_args()
    trees = {"this": HERE} | ({"before": a.before.resolve()} if a.before else {})
    load = os.getloadavg()[0]
    best: dict[str, dict[str, float]] = {name: {} for name in trees}
    for _ in range(a.repeat):
        for name, tree in trees.items():
            for key, value in measure(tree).items():
                best[name][key] = min(best[name].get(key, float("inf")), value)
    print(f"nproc {os.cpu_count()}, load {load:.2f} → {os.getloadavg()[0]:.2f}, best of {a.repeat} (CPU time)\n")
    names = list(trees)[::-1]
    print("| loop | " + " | ".join(names) + (" | before/this |" if a.before else " |"))
    print("|---|" + "---|" * (len(names) + bool(a.before)))
    for key in best["this"]:
        cells = [f"{best[n][key]:.3g}" for n in names]
        ratio = f" | {best['before'][key] / best['this'][key]:.2f}" if a.before else ""
        print(f"| {key} | " + " | ".join(cells) + ratio + " |")


if __name__ == "__main__":
    main()
