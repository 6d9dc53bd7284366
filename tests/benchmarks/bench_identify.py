"""Benchmark: identification speed (issue 5's targets).

    python tests/benchmarks/bench_identify.py            # both cases
    python tests/benchmarks/bench_identify.py --sdp      # only the LMI method on the Panda
    python tests/benchmarks/bench_identify.py --cli      # only the whole `pinid identify` run

1. The physically consistent estimator (``sdp``: pseudo-inertia LMI, Clarabel) on 20 000
   samples of the 7-DOF Panda (example-robot-data, fingers locked), noisy torques: ``SDP.fit``
   (QR compression of the 140 000-row base regressor, the conic problem, Clarabel), best of 3
   after one warm-up (not counted).  Building the problem (regressor, base
   columns, checks) is timed separately.  Target ≤ 1 s, status optimal.
2. ``pinid identify`` as a subprocess on 10 minutes of 1 kHz exo_leg data (a CSV with t, q and tau only,
   so the default preprocessing — zero-phase filter, Savitzky–Golay derivatives — runs) plus a
   2-minute validation recording, methods ols, wls, sdp, report and figures included: wall time of the
   whole command, Python start-up included.  Target ≤ 10 s.

Prints a Markdown table.  The data are analytic Fourier motions (seeded) with Gaussian torque noise.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pinid import TermSelection, RobotModel
from pinid.data.dataset import Dataset


def fourier(model, seconds: float, rate: float, seed: int):
    """(t, q, dq, ddq): a random 4-harmonic Fourier motion inside the position and velocity limits."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds * rate))) / rate
    lo = np.where(np.isfinite(model.lower), model.lower, -np.pi)
    hi = np.where(np.isfinite(model.upper), model.upper, np.pi)
    vmax = np.where(np.isfinite(model.velocity_limit), model.velocity_limit, 2.0)
    w = 2 * np.pi * 0.1 * np.arange(1, 5)
    a, b = rng.normal(size=(model.nv, 4)) / np.arange(1, 5), rng.normal(size=(model.nv, 4)) / np.arange(1, 5)
    s, c = np.sin(np.outer(t, w)), np.cos(np.outer(t, w))
    dev, vel, acc = s @ a.T + c @ b.T, (c * w) @ a.T - (s * w) @ b.T, -(s * w**2) @ a.T - (c * w**2) @ b.T
    k = np.minimum(0.85 * 0.5 * (hi - lo) / np.abs(dev).max(0), 0.85 * vmax / np.abs(vel).max(0))
    return t, 0.5 * (lo + hi) + k * dev, k * vel, k * acc


def recording(model, seconds, rate, seed, noise) -> Dataset:
    t, q, dq, ddq = fourier(model, seconds, rate, seed)
    fc, fv = np.full(model.nv, 0.5), np.full(model.nv, 0.3)
    tau = model.rnea(q, dq, ddq) + fc * np.sign(dq) + fv * dq
    tau += np.random.default_rng(seed + 100).normal(scale=noise, size=tau.shape)
    return Dataset(t, q, model.joint_names, dq=dq, ddq=ddq, tau=tau, source=f"fourier{seed}")


def best_of(fn, repeats: int = 3) -> tuple[float, object]:
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def bench_sdp() -> list[str]:
    from pinid.estimators import SDP
    from pinid.problem.problem import IdentificationProblem

    model = RobotModel.from_urdf("panda")
    ds = recording(model, 20.0, 1000.0, 0, noise=0.5)  # 20 000 samples
    t_build, problem = best_of(lambda: IdentificationProblem.from_datasets(model, ds, terms=TermSelection()), 1)
    SDP().fit(problem)  # warm-up: imports Clarabel

    def fit_from_scratch():
        problem.cache.forget("compressed")  # include the QR compression of the tall regressor
        return SDP().fit(problem)

    t_fit, est = best_of(fit_from_scratch)
    t_solve = est.info_.get("solve_seconds") or float("nan")
    return [
        f"| sdp on panda (7 DOF), 20 000 samples, {problem.rows} × {problem.nb} base regressor: fit "
        f"(QR + Clarabel {t_solve:.3f} s) | {t_fit:.3f} | 1.0 | {est.status_} |",
        f"| — building that problem (regressor, base columns, rank check) | {t_build:.2f} | – | |",
    ]


def bench_cli() -> list[str]:
    from pinid.data.formats import write_recording

    model = RobotModel.from_urdf("exo_leg")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, seconds, seed in (("train", 600.0, 1), ("valid", 120.0, 2)):
            ds = recording(model, seconds, 1000.0, seed, noise=0.3)
            write_recording(tmp / f"{name}.csv", Dataset(ds.t, ds.q, ds.joints, tau=ds.tau))
        cmd = [
            sys.executable,
            "-m",
            "pinid.cli",
            "identify",
            "--urdf",
            "exo_leg",
            "--data",
            str(tmp / "train.csv"),
            "--validate",
            str(tmp / "valid.csv"),
            "--methods",
            "ols,wls,sdp",
            "-o",
            str(tmp / "out"),
            "--force",
        ]  # runs twice
        times, cpu = [], []
        for _ in range(2):
            r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            proc = subprocess.run(cmd, capture_output=True, text=True)
            times.append(time.perf_counter() - t0)
            r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu.append(r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
            if proc.returncode != 0:
                raise SystemExit(proc.stderr)
        status = "ok" if (tmp / "out" / "identification.json").is_file() else "no output"
    k = int(np.argmin(times))
    return [
        f"| `pinid identify`, exo_leg, 10 min at 1 kHz (+2 min validation), ols,wls,sdp, report: wall "
        f"(CPU) | {times[k]:.2f} ({cpu[k]:.2f} CPU), best of 2 | 10 | {status} |"
    ]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sdp", action="store_true", help="only the LMI method on the Panda")
    p.add_argument("--cli", action="store_true", help="only the whole pinid identify run")
    args = p.parse_args()
    both = not (args.sdp or args.cli)
    print(
        f"machine: {platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}, "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}\n"
    )
    print("| case | time [s] | target [s] | status |")
    print("|---|---|---|---|")
    if both or args.sdp:
        print("\n".join(bench_sdp()), flush=True)
    if both or args.cli:
        print("\n".join(bench_cli()), flush=True)


if __name__ == "__main__":
    main()
