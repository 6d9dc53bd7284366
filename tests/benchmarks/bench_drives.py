"""Benchmark: identification with drives costs at most 1.2× the same run without (issue 13).

    python tests/benchmarks/bench_drives.py

ur5 (example-robot-data) with 1:50 reductions on joints 1–4 and a differential wrist (motor 6 turns with
q5 + q6), 26 000 samples of an analytic Fourier motion, noisy torques (σ = 0.1 N·m).  ``pinid.identify``
with methods ols and sdp (regressor, base columns, checks, both estimators, validation on 2 000 samples),
best of 3 after one warm-up run: with terms ``fc,fv`` (no drives), with six joint terms per joint (as
many term parameters as the drive model, no drives) and with ``fc,fv,motor_fc,motor_fv,motor_offset,
motor_armature``.  The extra cost of drives is the extra columns (the QR of the tall regressor grows
with their number), not the transmission.  Also prints the coupled joints' validation RMS of both runs on the
torques of the drive model.  Prints a Markdown table.
"""

from __future__ import annotations

import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import conftest  # noqa: E402,F401  (puts the test folders on sys.path)

from test_drives import MOTOR_TERMS, coupled, twin  # noqa: E402

from pinid import TermSelection  # noqa: E402
from pinid.identification.study import Study
from pinid.identification.run import identify  # noqa: E402


def best_of(fn, repeats: int = 3):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> None:
    model = coupled("ur5")
    train = twin(model, MOTOR_TERMS, seconds=104.0, rate=250.0, seed=4, noise=0.1)  # 26 000 samples
    valid = twin(model, MOTOR_TERMS, seconds=8.0, rate=250.0, seed=5, noise=0.1)
    rows = []
    times = {}
    cases = (
        ("without drives (fc,fv)", TermSelection()),
        (
            "without drives, as many terms (fc,fv,offset,armature,fc_pos,fc_neg)",
            TermSelection.from_names("fc,fv,offset,armature,fc_pos,fc_neg"),
        ),
        ("with drives (+ 4 motor terms)", MOTOR_TERMS),
    )
    for label, terms in cases:
        run = lambda: identify(Study(model, train, validate=valid, terms=terms), methods=["ols", "sdp"])  # noqa: E731
        run()  # warm-up (imports, caches)
        t, res = best_of(run)
        times[label] = t
        rms = {j: res["sdp"].validation.per_joint[j]["rms"] for j in model.joint_names[-2:]}
        rows.append(
            f"| {label} | {len(train.t)} | {res['ols'].base.size} | {t:.2f} | "
            + ", ".join(f"{j} {v:.3f}" for j, v in rms.items())
            + f" | {res['sdp'].validation.all['rms']:.3f} |"
        )
    t_with = times["with drives (+ 4 motor terms)"]
    ratio = t_with / times["without drives (fc,fv)"]
    ratio_same = t_with / times[cases[1][0]]
    print(
        f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}"
    )
    print(
        "| run | samples | base parameters | identify ols+sdp [s] | coupled joints' validation RMS [N·m] "
        "| all joints [N·m] |"
    )
    print("|---|---|---|---|---|---|")
    print("\n".join(rows))
    print(
        f"\nratio with drives / fc,fv only: {ratio:.2f}; with drives / joint model with as many terms: "
        f"{ratio_same:.2f} (target ≤ 1.2); noise floor σ = 0.1 N·m"
    )


if __name__ == "__main__":
    main()
