"""Benchmark: what each friction model costs in conditioning (issue 13; docs/drives.md).

    python tests/benchmarks/bench_friction_conditioning.py

The same noise-free twin recordings (tests/model/test_stribeck.py: analytic Fourier motion, 30 s at 200 Hz)
for every row: exo_leg (joint terms) and exo_leg with the cable coupling G = [[30, 0], [12, 25]] (motor
terms).  For each set of terms, the base regressor W_b of ``IdentificationProblem.from_datasets`` with
every row kept (``rest_velocity=0``, so every row sees the same samples) and its condition number as it
is and with unit-norm columns (what ``pinid identify`` reports as cond / cond scaled).  Stribeck rows
for several velocities v_s [rad/s] (shape 2).  Prints a Markdown table.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import conftest  # noqa: E402,F401  (puts the test folders on sys.path)

from test_stribeck import JOINT, MOTOR, exo_joint, exo_motor, twin  # noqa: E402

from pinid import TermSelection  # noqa: E402
from pinid.problem.problem import IdentificationProblem
from pinid.problem.statistics import base_statistics
from pinid.identification.stribeck import with_stribeck  # noqa: E402
from pinid.model.terms import Stribeck  # noqa: E402

CASES = [
    (
        "exo_leg",
        exo_joint,
        JOINT,
        [
            ("fv", None),
            ("fc,fv", None),
            ("fc,fv,offset", None),
            ("fc_pos,fc_neg,fv", None),
            ("fc,fv,armature", None),
            ("fc,fv,fs", ("fs", 0.05)),
            ("fc,fv,fs", ("fs", 0.25)),
            ("fc,fv,fs", ("fs", 1.0)),
        ],
    ),
    (
        "exo_leg, cable",
        exo_motor,
        MOTOR,
        [
            ("fc,fv", None),
            ("fc,fv,motor_fc", None),
            ("fc,fv,motor_fc,motor_fv", None),
            ("fc,fv,motor_fc,motor_fs", ("motor_fs", 1.5)),
            ("fc,fv,motor_fc,motor_fs", ("motor_fs", 6.0)),
            ("fc,fv,motor_fc,motor_fs", ("motor_fs", 24.0)),
        ],
    ),
]


def main() -> None:
    print("| robot | terms | Stribeck v_s [rad/s] | nb | cond(W_b) | cond, unit columns |")
    print("|---|---|---|---|---|---|")
    for label, make, truth_terms, rows in CASES:
        m = make()
        ds, _ = twin(m, truth_terms)
        for names, shape in rows:
            model = with_stribeck(m, {shape[0]: Stribeck(shape[1], 2.0)}) if shape else m
            p = IdentificationProblem.from_datasets(model, ds, terms=TermSelection.from_names(names), rest_velocity=0)
            _, cond, scaled = base_statistics(p, p.nominal_base)
            vs = "" if shape is None else f"{shape[1]:g}"
            print(f"| {label} | {names} | {vs} | {p.nb} | {cond:.3g} | {scaled:.3g} |")


if __name__ == "__main__":
    main()
