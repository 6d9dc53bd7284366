"""Checks on the real DFKI double-pendulum recordings quoted in docs/identification.md.

    python tests/benchmarks/real_data_checks.py [--data ../shared/data/double_pendulum]

1. How closely the measured torque (``tau_meas``, from the motor current) follows the controller's command
   (``tau_con``): correlation per joint on trajectory 03.
2. Whether a time lag between torques and positions explains joint 1's poor fit: OLS trained on trajectory
   02 and validated on 03 with the torques shifted by L samples (L > 0 pairs q[k] with tau[k + L]),
   validation relative RMS per joint.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

from pinid import RobotModel
from pinid.data.formats import read_recording
from pinid.data.dataset import Dataset
from pinid.estimators import make_estimator
from pinid.problem.problem import IdentificationProblem
from pinid.problem.recordings import prepare_dataset

ROOT = Path(__file__).resolve().parents[2]
SPEC = ROOT / "docs" / "examples" / "double_pendulum.toml"


def shifted(ds: Dataset, lag: int) -> Dataset:
    """``ds`` with its torques shifted by ``lag`` samples against q, dq, ddq."""
    if lag == 0:
        return ds
    a, b = (slice(None, -lag), slice(lag, None)) if lag > 0 else (slice(-lag, None), slice(None, lag))
    return Dataset(ds.t[a], ds.q[a], ds.joints, dq=ds.dq[a], ddq=ds.ddq[a], tau=ds.tau[b], source=ds.source)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "double_pendulum"))
    args = p.parse_args(argv)
    data = Path(args.data)
    raw = np.genfromtxt(data / "trajectory_03.csv", delimiter=",", names=True)
    print("| joint | corr(tau_meas, tau_con) | RMS tau_meas [N·m] | RMS tau_meas − tau_con [N·m] |")
    print("|---|---|---|---|")
    for j in (1, 2):
        m, c = raw[f"tau_meas{j}"], raw[f"tau_con{j}"]
        print(f"| Joint{j} | {np.corrcoef(m, c)[0, 1]:.3f} | {m.std():.3f} | {(m - c).std():.3f} |")

    model = RobotModel.from_urdf(data / "double_pendulum.urdf")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        train, valid = (
            prepare_dataset(read_recording(data / f"trajectory_{n}.csv", model=model, mapping=SPEC))
            for n in ("02", "03")
        )
    dt = float(np.median(np.diff(train.t)))
    print(f"\nOLS, train 02, validate 03; torques shifted by L samples of {1e3 * dt:.1f} ms\n")
    print("| L | shift [ms] | validation rel. RMS Joint1 [%] | Joint2 [%] |")
    print("|---|---|---|---|")
    for lag in (-20, -10, -5, 0, 5, 10, 20, 40):
        fit = IdentificationProblem.from_datasets(model, [shifted(train, lag)])
        x = make_estimator("ols").fit(fit).base_
        val = IdentificationProblem.from_datasets(model, [shifted(valid, lag)], rest_velocity=0)
        r = val.tau - val.W @ x
        rel = [100 * np.sqrt(np.mean(r[val.joint == j] ** 2) / np.mean(val.tau[val.joint == j] ** 2)) for j in range(2)]
        print(f"| {lag} | {1e3 * lag * dt:.0f} | {rel[0]:.1f} | {rel[1]:.1f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
