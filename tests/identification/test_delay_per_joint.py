"""One torque delay per channel (``--delay auto-per-joint``, issue 34): on the 1 kHz twin, the torques of two
joints recorded 10 ms and 30 ms late give each delay back to within one sample."""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest

from pinid.data.dataset import Dataset
from pinid.identification.study import Study
from pinid.data.delay import parse_delay, shifted
from pinid.errors import SpecError
from pinid.identification.delay import estimate_delay
from pinid.identification.outputs import identification_text
from pinid.identification.run import identify
from pinid.model.robot import RobotModel
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.twin import simulate

LAGS = np.array([0.010, 0.030])  # hip, knee [s]


@functools.cache
def _true_signals(seed: int, seconds: float):
    """The twin's true signals at 1 kHz, simulated once per test run (only read: the recordings index copies)."""
    m = RobotModel.from_urdf("exo_leg")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # zha2019-4 is faster than exo_leg's URDF limits: a DataWarning
        _, truth = simulate(m, load_trajectory("zha2019-4", m), seconds=seconds, seed=seed, torque_noise=0.0)
    return truth["signals"]


def recording(seed: int, noise: float = 0.0, seconds: float = 8.0) -> Dataset:
    """The twin's true motion at 1 kHz, each torque channel recorded ``LAGS[j]`` late (plus noise)."""
    m = RobotModel.from_urdf("exo_leg")
    s = _true_signals(seed, seconds)
    tau = np.column_stack([shifted(s.t, s.tau[:, j], s.t - LAGS[j]) for j in range(2)])
    tau += np.random.default_rng(seed).normal(size=tau.shape) * noise
    keep = s.t >= LAGS.max()
    return Dataset(s.t[keep], s.q[keep], m.joint_names, dq=s.dq[keep], ddq=s.ddq[keep], tau=tau[keep], source="lag")


@pytest.mark.parametrize("noise", [0.0, 0.05])
def test_each_channels_delay_is_found_to_within_one_sample(noise):
    m = RobotModel.from_urdf("exo_leg")
    ds = recording(2, noise)
    found = estimate_delay(m, [ds], per_joint=True)
    assert found["per_channel"]
    np.testing.assert_allclose(found["per_joint_delays"], LAGS, atol=1e-3)
    assert LAGS[0] - 1e-3 < found["delay"] < LAGS[1] + 1e-3  # the shared start lies between
    assert "per_joint_delays" not in estimate_delay(m, [ds])  # auto: one delay, as before


@pytest.mark.filterwarnings("ignore:.*repeats the trajectory")  # one excitation, two noise draws: the point here
def test_identify_applies_the_per_channel_delays_and_reports_them():
    m = RobotModel.from_urdf("exo_leg")
    res = identify(Study(m, recording(2), validate=recording(3, seconds=5.0), delay="auto-per-joint"), methods="ols")
    d = res.data["delay"]
    assert d["estimated"] and d["per_channel"]
    np.testing.assert_allclose([d["per_joint"][j] for j in m.joint_names], LAGS, atol=1e-3)
    assert res["ols"].validation.all["rel_rms_percent"] < 1.0
    assert "hip 10" in identification_text(res) and "knee 30" in identification_text(res)
    shared = identify(Study(m, recording(2), validate=recording(3, seconds=5.0), delay="auto"), methods="ols")
    assert shared["ols"].validation.all["rms"] > 5 * res["ols"].validation.all["rms"]


def test_the_option_parses():
    assert parse_delay("auto-per-joint", ["hip", "knee"]) == "auto-per-joint"
    assert parse_delay("tau=auto-per-joint", ["hip", "knee"]) == "auto-per-joint"
    with pytest.raises(SpecError, match="auto-per-joint"):
        parse_delay("tau.knee=auto", ["hip", "knee"])
    with pytest.raises(SpecError, match="per_joint"):
        estimate_delay(RobotModel.from_urdf("exo_leg"), [], per_joint="yes")
