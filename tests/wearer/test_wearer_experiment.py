"""Issue 18's figures on the twin (shortened; tests/benchmarks/bench_wearer.py prints the full ones)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pinid.control.tracking import sine_reference
from pinid.excitation.trajectory import FourierTrajectory
from pinid.model.robot import RobotModel
from pinid.wearer.attach import wearer_urdf
from pinid.wearer.experiment import WearerTrial, wearer_experiment

HERE = Path(__file__).resolve().parents[2] / "excitation"


def test_trial_settings_are_checked():
    from pinid.errors import SpecError

    for bad, field in (
        ({"seconds": 0}, "seconds"),
        ({"seed": 1.5}, "seed"),
        ({"true_exponents": [1]}, "true_exponents"),
    ):
        with pytest.raises(SpecError, match=f"WearerTrial {field}"):
            WearerTrial(**bad)
    with pytest.raises(SpecError, match="expected WearerTrial"):
        wearer_experiment("exo_leg", "exo_leg", None, None, None, trial={"seconds": 10})


@pytest.mark.slow
@pytest.mark.parametrize("active", [0.0, 5.0])
def test_identified_wearer_beats_tables_in_torque_and_tracking(tmp_path, active):
    path = tmp_path / "exo_with_wearer.urdf"
    wearer_urdf("exo_leg", "hip:thigh,knee:shank,knee:foot", mass=75, height=1.78, sex="male", path=path)
    r = wearer_experiment(
        "exo_leg",
        path,
        FourierTrajectory.load(HERE / "exo_leg.json"),
        FourierTrajectory.load(HERE / "seed001_table3.json"),
        sine_reference(RobotModel.from_urdf(path)),
        trial=WearerTrial(seconds=10.0 if active == 0 else 20.0, wearer_torque=active, track_seconds=4.0),
    )
    ratio = r["ratio"]
    if active == 0:  # sensor noise only: the identified wearer is at the floor, the tables far above it
        assert ratio["identified"] <= 1.1 and ratio["table"] >= 3 * ratio["identified"]
    # with the active torque a 20 s recording is too short for the torque figures (part of the disturbance
    # is absorbed, docs/wearer.md); the tracking figures hold
    assert ratio["exo"] > 3 * max(ratio["table"], ratio["identified"])
    for c, by in r["tracking"].items():
        rms = {w: float(np.sqrt(np.mean(v**2))) for w, v in by.items()}
        assert rms["identified"] <= 0.5 * rms["table"] < 0.5 * rms["exo"], (c, rms)
