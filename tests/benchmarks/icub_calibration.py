"""The iCub walk with and without the sensor calibration (issue 46, docs/floating-base.md): per-axis validation error.

Converts ../shared/data/icub_walking/walking.mat (tests/benchmarks/icub_walking_csv.py: first 70 % training,
last 30 % validation), stacks the base rows as ``pinid identify --base floating --rows base --cutoff 4 --joints
<the 26 recorded joints>`` does with ``--calibration`` none and auto, fits OLS and SDP, and prints per method the
stacked relative RMS of the base wrench on the validation part, each axis's (fx fy fz [N], tx ty tz [N·m], base
frame), the total mass, the model-class floor (OLS fitted on the validation rows themselves) and the calibration
with its σ.

    python tests/benchmarks/icub_calibration.py [OUT_DIR]
"""

from __future__ import annotations

import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import icub_walking_csv as walk  # noqa: E402

from pinid import RobotModel  # noqa: E402
from pinid.estimators import make_estimator  # noqa: E402
from pinid.identification.calibration import total_mass_vector  # noqa: E402
from pinid.identification.run import setup  # noqa: E402
from pinid.identification.study import Study  # noqa: E402

AXES = ("fx", "fy", "fz", "tx", "ty", "tz")


def rel(e: np.ndarray, y: np.ndarray) -> float:
    return 100 * float(np.sqrt(np.sum(e**2) / np.sum(y**2)))


def main(out: str | None = None) -> None:
    out = Path(out or tempfile.mkdtemp())
    walk.main(out)
    model = RobotModel.from_urdf(str(walk.URDF), base="floating", joints=walk.JOINTS)
    for calibration in ("none", "auto"):
        study = Study(
            model,
            data=str(out / "train.csv"),
            validate=str(out / "val.csv"),
            preprocess={"cutoff": 4.0},
            floating={"rows": "base", "calibration": calibration},
        )
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            s = setup(study)
        train, val = s.problem, s.floating.validation
        c = total_mass_vector(train.base)
        print(f"\ncalibration {calibration} ({time.perf_counter() - t0:.0f} s to stack and calibrate)")
        if s.floating.calibration is not None:
            print(s.floating.calibration.text())
        floor = make_estimator("ols").fit(val).base_
        print(f"  class floor {rel(val.tau - val.W @ floor, val.tau):.2f} %")
        for method in ("ols", "sdp"):
            theta = make_estimator(method).fit(train).base_
            e = val.tau - val.W @ theta
            axes = ", ".join(f"{a} {rel(e[k::6], val.tau[k::6]):.1f}" for k, a in enumerate(AXES))
            print(
                f"  {method}: validation {rel(e, val.tau):.2f} % (per axis %: {axes}), training "
                f"{rel(train.tau - train.W @ theta, train.tau):.2f} %, total mass {float(c @ theta):.2f} kg"
            )


if __name__ == "__main__":
    main(*sys.argv[1:])
