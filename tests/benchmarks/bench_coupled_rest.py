"""The coupled joint: motor Coulomb friction with the rows of a motor at rest left out, or kept (issue 28).

ur5 with 1:50 reductions and a differential wrist (motor 6 turns with q5 + q6; tests/model/test_drives.py's
``coupled``), terms fc,fv + motor fc, fv, offset, rotor inertia.  Training: 30 s at 250 Hz, exact torques,
measured velocities with white noise σ = 0.02 rad/s (the sign of a velocity near zero is then a coin toss);
validation: 10 s, exact.  Prints, per seed, the coupled joint's (wrist_3) validation RMS and motor 6's
Coulomb friction with the motor rule (``motor_kept_rows``) and without it.

    python tests/benchmarks/bench_coupled_rest.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import conftest  # noqa: E402,F401  (puts the test folders on sys.path)

import pinid.problem.problem as problem  # noqa: E402
from pinid.identification.study import Study
from pinid import base_parameters, standard_parameters  # noqa: E402
from pinid.data.dataset import Dataset  # noqa: E402
from pinid.identification.run import identify  # noqa: E402
from test_drives import MOTOR_TERMS, coupled, twin  # noqa: E402


def main() -> None:
    m = coupled("ur5")
    bp = base_parameters(m, MOTOR_TERMS)
    truth = bp.from_standard(standard_parameters(m, MOTOR_TERMS))
    i = bp.names.index("m6.fc")
    rule = problem.motor_kept_rows
    print("seed  wrist_3 valid. RMS [N·m] with / without   m6.fc with / without (truth)")
    for seed in range(3):
        clean = twin(m, MOTOR_TERMS, seconds=30, rate=250, seed=10 + seed)
        noise = np.random.default_rng(seed).normal(size=clean.dq.shape) * 0.02
        train = Dataset(clean.t, clean.q, clean.joints, dq=clean.dq + noise, ddq=clean.ddq, tau=clean.tau)
        valid = twin(m, MOTOR_TERMS, seconds=10, rate=250, seed=50 + seed)
        out = []
        for on in (True, False):
            problem.motor_kept_rows = rule if on else (lambda ds, *a, **k: np.ones(ds.dq.size, bool))
            r = identify(Study(m, train, validate=valid, terms=MOTOR_TERMS), methods="ols")["ols"]
            out.append((r.validation.per_joint["wrist_3_joint"]["rms"], r.base[i]))
        problem.motor_kept_rows = rule
        print(
            f"{seed:4d}  {out[0][0]:.4f} / {out[1][0]:.4f}                  "
            f"{out[0][1]:.5f} / {out[1][1]:.5f} ({truth[i]:g})"
        )


if __name__ == "__main__":
    main()
