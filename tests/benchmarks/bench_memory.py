"""Benchmark: peak memory of `pinid identify` on a long recording of a 7-DOF arm (issue 17).

    python tests/benchmarks/bench_memory.py                     # 500 000 samples of panda, ols
    python tests/benchmarks/bench_memory.py --samples 100000 --methods ols,sdp
    python tests/benchmarks/bench_memory.py --robot exo_leg --samples 100000 1000000 --methods ols,wls,sdp
    python tests/benchmarks/bench_memory.py --before /tmp/before   # an older checkout too, same file, one run

Writes a recording of the Panda (example-robot-data, 7 DOF) following a random Fourier trajectory inside
its limits at 1 kHz — q, dq, ddq exact, τ = W(q, dq, ddq)·θ_URDF (friction fc, fv from the URDF) plus
0.01 N·m noise — as NPZ, then runs ``pinid identify --urdf panda --data FILE --methods M --no-report`` in
a fresh process (per tree with ``--before``) and prints its wall time and peak resident memory
(``ru_maxrss`` of that child, from ``os.wait4`` in a small process between this one and the child, see
``MEASURE``), with the size of the recording and of the tall base regressor for comparison.
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pinid import RobotModel
from pinid.data.dataset import Dataset
from pinid.data.formats import write_recording
from pinid.excitation.problem import DesignProblem
from pinid.excitation.spec import spec_for
from pinid.model.base import base_parameters
from pinid.model.regressor import regressor, standard_parameters

HERE = Path(__file__).resolve().parents[2]


def recording(path: Path, samples: int, seed: int = 0, robot: str = "panda") -> int:
    """Write the recording; returns the number of base parameters."""
    model = RobotModel.from_urdf(robot)
    spec = spec_for(model)
    problem = DesignProblem(model, spec)
    lower, upper = problem.box()
    rng = np.random.default_rng(seed)
    x = problem.scale_into_limits(lower + rng.random(problem.d) * (upper - lower))[0]
    traj = problem.trajectory(x)
    t = np.arange(samples) / 1000.0
    q, dq, ddq = traj.evaluate(t)
    theta = standard_parameters(model, spec.terms)
    tau = np.empty_like(q)
    for s in range(0, samples, 50_000):
        e = min(samples, s + 50_000)
        tau[s:e] = (regressor(model, q[s:e], dq[s:e], ddq[s:e], spec.terms) @ theta).reshape(e - s, -1)
    tau += 0.01 * rng.standard_normal(tau.shape)
    write_recording(path, Dataset(t, q, model.joint_names, dq, ddq, tau, source=path.name))
    return base_parameters(model, spec.terms).count


#: Runs its arguments as a child and prints the child's peak RSS [kB] (``ru_maxrss`` of ``os.wait4``) on its
#: last stderr line.  A small process in between: Linux keeps the RSS of the process that forked a child as
#: the floor of that child's ``ru_maxrss`` (the old address space's high-water mark is kept across exec), and
#: this script holds the recording it wrote (about 300 MB for 1 M exo_leg samples) — a floor, not the child's.
MEASURE = """
import os, subprocess, sys
proc = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
err = proc.stderr.read()
_, status, usage = os.wait4(proc.pid, 0)
sys.stderr.write(err + f"\\nmaxrss_kb {usage.ru_maxrss} status {status}\\n")
"""


def identify(tree: Path, folder: Path, methods: str, robot: str = "panda") -> tuple[float, float]:
    """(wall [s], peak RSS [MB]) of ``pinid identify`` on ``folder/<robot>.npz`` with ``tree`` on the path."""
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg", OPENBLAS_NUM_THREADS="1")
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            MEASURE,
            sys.executable,
            "-m",
            "pinid.cli",
            "identify",
            "--urdf",
            robot,
            "--data",
            f"{robot}.npz",
            "--methods",
            methods,
            "--no-report",
            "--force",
            "-o",
            "out",
        ],
        cwd=folder,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    err = proc.stderr.read()
    proc.wait()
    wall = time.perf_counter() - t0
    proc.stderr.close()
    last = err.strip().splitlines()[-1].split() if err.strip() else []
    if proc.returncode or len(last) != 4 or last[0] != "maxrss_kb" or last[3] != "0":
        raise SystemExit(err)
    return wall, int(last[1]) / 1024  # Linux: kB


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--samples", type=int, nargs="+", default=[500_000], help="one or more lengths")
    ap.add_argument("--robot", default="panda", help="robot name (default panda)")
    ap.add_argument("--methods", default="ols")
    ap.add_argument("--before", type=Path, help="an older checkout to measure on the same file")
    a = ap.parse_args()
    print(
        f"machine: {platform.machine()}, nproc {os.cpu_count()}, python {platform.python_version()}, "
        f"load {os.getloadavg()[0]:.2f}"
    )
    peaks = []
    for samples in a.samples:
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            nb = recording(d / f"{a.robot}.npz", samples, robot=a.robot)
            size = (d / f"{a.robot}.npz").stat().st_size
            nv = RobotModel.from_urdf(a.robot).nv
            rows = samples * nv
            print(f"{a.robot}, {samples} samples ({rows} torque rows, {nb} base parameters), NPZ {size / 1e6:.0f} MB")
            print(f"tall base regressor alone (float64): {rows * nb * 8 / 1e6:.0f} MB")
            trees = ([("before", a.before.resolve())] if a.before else []) + [("this", HERE)]
            for name, tree in trees:
                wall, peak = identify(tree, d, a.methods, a.robot)
                print(
                    f"{name}: `pinid identify --urdf {a.robot} --methods {a.methods} --no-report`: {wall:.1f} s wall, "
                    f"peak RSS {peak:.0f} MB"
                )
            peaks.append((samples, peak))
    if len(peaks) > 1:
        (n0, p0), (n1, p1) = peaks[0], peaks[-1]
        print(f"slope: {(p1 - p0) * 2**20 / (n1 - n0):.0f} bytes per sample ({a.robot}, {a.methods})")


if __name__ == "__main__":
    main()
