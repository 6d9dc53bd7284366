"""Benchmark: reading and preprocessing a long recording (issue 4's speed figure), and the twin's speed.

    python tests/benchmarks/bench_data.py

Writes 10 minutes of a 7-DOF recording at 1 kHz (600 000 samples of the Panda, fingers locked: t, q, tau
= 15 columns; and the same with measured velocities, 22 columns) as CSV and NPZ in a temporary folder,
then times, best of 3: ``read_recording`` with the model (reorder and checks), ``prepare`` with its
defaults (10 Hz zero-phase Butterworth, Savitzky–Golay derivatives, trimming), and both together.
Also times ``simulate`` for 60 s of exo_leg at 1 kHz.  Prints Markdown tables.  Target: a few seconds.
"""

from __future__ import annotations

import platform
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

from pinid import RobotModel
from pinid.data.formats import read_recording, write_recording
from pinid.data.dataset import Dataset
from pinid.data.preprocess import prepare
from pinid.simulation.twin import simulate
from pinid.excitation.trajectory import FourierTrajectory


def best_time(fn, repeats: int = 3) -> tuple[float, object]:
    """Best wall time of ``repeats`` calls [s], and the last result."""
    best, out = np.inf, None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def recording(model: RobotModel, seconds: float, rate: float, velocity: bool) -> Dataset:
    rng = np.random.default_rng(0)
    lo, hi = model.lower, model.upper
    mid, amp = 0.5 * (lo + hi), 0.2 * (hi - lo)
    t = np.arange(int(seconds * rate)) / rate
    traj = FourierTrajectory(
        model.joint_names,
        0.2 * np.pi,
        mid,
        amp[:, None] * rng.uniform(-0.5, 0.5, (model.nv, 4)),
        amp[:, None] * rng.uniform(-0.5, 0.5, (model.nv, 4)),
    )
    q, dq, ddq = traj.evaluate(t)
    tau = ddq + 5 * np.sin(q) + 0.3 * dq
    return Dataset(
        t=t,
        q=q + rng.normal(0, 1e-4, q.shape),
        joints=model.joint_names,
        dq=dq + rng.normal(0, 1e-2, q.shape) if velocity else None,
        tau=tau + rng.normal(0, 0.05, q.shape),
    )


def main() -> None:
    print(f"machine: {platform.processor() or platform.machine()}, python {platform.python_version()}\n")
    panda = RobotModel.from_urdf("panda")
    print("| file | columns | size [MB] | read [s] | prepare [s] | read + prepare [s] |")
    print("|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for velocity in (False, True):
            ds = recording(panda, 600.0, 1000.0, velocity)
            for suffix in (".csv", ".npz"):
                path = Path(tmp) / f"panda{suffix}"
                write_recording(path, ds)
                t_read, back = best_time(lambda: read_recording(path, model=panda))
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    t_prep, _ = best_time(lambda: prepare(back))
                    t_both, _ = best_time(lambda: prepare(read_recording(path, model=panda)))
                cols = 1 + panda.nv * (3 if velocity else 2)
                print(
                    f"| {suffix[1:].upper()}, 600 000 × 7 DOF{' + dq' if velocity else ''} | {cols} | "
                    f"{path.stat().st_size / 1e6:.0f} | {t_read:.2f} | {t_prep:.2f} | {t_both:.2f} |"
                )
    exo = RobotModel.from_urdf("exo_leg")
    traj = FourierTrajectory(
        exo.joint_names, 0.2 * np.pi, [0.6107, -0.8727], [[0.3, 0.05], [-0.3, 0.05]], [[0.0, 0.05], [0.1, 0.0]]
    )
    t_sim, (rec, _) = best_time(lambda: simulate(exo, traj, seconds=60.0, seed=1), repeats=1)
    print("\n| twin | samples | integration grid | time [s] |")
    print("|---|---|---|---|")
    print(f"| simulate exo_leg, 60 s, 1 kHz control and sampling | {rec.n} | 2 kHz | {t_sim:.2f} |")


if __name__ == "__main__":
    main()
