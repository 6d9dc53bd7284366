"""Issue 32: one twin entry point whatever the base.  ``simulate`` and ``simulate_and_write`` of a floating
model give exactly what the floating twin's own functions give (seeded, exact equality), unpack as the
fixed-base ``(recording, truth)``, and refuse an option of the other kind of model with a one-line SpecError."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import floating_excitation, load
from pinid.data.formats import read_recording
from pinid.errors import SpecError
from pinid.simulation.floating_twin import BaseSensors, Noise, TwinRun, simulate_gait, simulate_suspended
from pinid.simulation.run import Outputs, simulate_and_write
from pinid.simulation.twin import Controller, Friction, Rates, Sensors, simulate, truth_json

NOISE = Noise(1e-4, 0.2, 1.0, 0.1, 0.004, 0.04)


def same_run(a: TwinRun, b: TwinRun) -> None:
    """Exact equality of two floating runs: every recorded column, the exact joint samples and the truth."""
    ca, cb = a.recording.floating.columns(), b.recording.floating.columns()
    assert list(ca) == list(cb)
    for k in ca:
        np.testing.assert_array_equal(ca[k], cb[k], err_msg=k)
    for k in ("t", "q", "tau"):
        np.testing.assert_array_equal(getattr(a.recording, k), getattr(b.recording, k), err_msg=k)
    for k in ("q", "dq", "ddq", "tau"):
        np.testing.assert_array_equal(getattr(a.exact.data, k), getattr(b.exact.data, k), err_msg=k)
    np.testing.assert_array_equal(a.exact.base_a, b.exact.base_a)
    assert json.dumps(truth_json(a.truth), sort_keys=True) == json.dumps(truth_json(b.truth), sort_keys=True)


@pytest.mark.parametrize("seed", [0, 3])
def test_simulate_of_a_floating_model_is_the_gait_twin(floating_exo, seed):
    old = simulate_gait(floating_exo, seconds=1.0, rate=200, noise=NOISE, seed=seed)
    new = simulate(floating_exo, "gait", seconds=1.0, seed=seed, rates=Rates(sample=200), noise=NOISE)
    same_run(old, new)
    same = simulate(floating_exo, "gait", seconds=1.0, seed=seed, sample_rate=200, sensors=BaseSensors(NOISE))
    same_run(old, same)
    same_run(old, simulate(floating_exo, "gait", seconds=1.0, seed=seed, sensors=BaseSensors(NOISE, None, 200)))
    rec, truth = new  # unpacks as the fixed-base (recording, truth)
    assert rec is new.recording and truth is new.truth and rec.floating.imu_frame is None
    assert rec.floating.base_pose is not None  # motion capture: what the force plates need
    assert truth["signals"] is new.exact.data  # the exact signals, as the fixed twin's truth carries them


def test_the_gait_twin_refuses_an_imu_identify_would_refuse(floating_exo):
    """Issue 47: an IMU alone does not locate the force plates; the gait with one wrote a file identify refused."""
    with pytest.raises(SpecError, match="IMU frame 'imu' with the gait: its force plates need the base position"):
        simulate_gait(floating_exo, seconds=1.0, rate=200, imu_frame="imu")
    with pytest.raises(SpecError, match="with the gait"):
        simulate(floating_exo, "gait", seconds=1.0, sensors=BaseSensors(NOISE, "imu", 200))


def test_simulate_of_a_floating_model_is_the_suspended_twin(floating_exo):
    traj = floating_excitation(floating_exo)
    old = simulate_suspended(floating_exo, traj, seconds=1.0, rate=250, noise=NOISE, seed=1)
    same_run(old, simulate(floating_exo, traj, seconds=1.0, seed=1, rates=Rates(control=250), noise=NOISE))


@pytest.mark.parametrize(
    "option",
    [
        {"controller": Controller()},
        {"controller": "pid"},
        {"friction": Friction()},
        {"wearer_torque": 5.0},
        {"terms": {}},
        {"bandwidth": 8.0},
        {"position_noise": 0.0},
        {"sensors": Sensors()},
    ],
)
def test_fixed_base_options_refused_for_a_floating_model(floating_exo, option):
    with pytest.raises(SpecError) as e:
        simulate(floating_exo, "gait", seconds=0.5, **option)
    name = next(iter(option))
    assert name in str(e.value) and "\n" not in str(e.value)


@pytest.mark.parametrize("rate", [{"rates": Rates(sample=200)}, {"sample_rate": 200}, {"control_rate": 500}])
def test_a_rate_in_base_sensors_and_in_rates_is_refused(floating_exo, rate):
    """BaseSensors.rate is the floating twin's sample rate; another one beside it is refused, not chosen."""
    with pytest.raises(SpecError, match=r"^sensors rate 250 Hz: a second rate in rates or \*_rate=, expected one$"):
        simulate(floating_exo, "gait", seconds=0.5, sensors=BaseSensors(rate=250), **rate)


@pytest.mark.parametrize(
    ("trajectory", "option", "name"),
    [
        ("gait", {}, "gait"),
        (None, {"noise": Noise()}, "noise"),
        (None, {"imu_frame": "imu"}, "imu_frame"),
        (None, {"sensors": BaseSensors()}, "sensors"),
    ],
)
def test_floating_options_refused_for_a_fixed_model(trajectory, option, name):
    from pinid.simulation.trajectories import load_trajectory

    model = load("exo_leg")
    with pytest.raises(SpecError) as e:
        simulate(model, trajectory or load_trajectory("exo_leg", model), seconds=0.5, **option)
    assert str(e.value).startswith(f"{name}: for a floating-base model only") and "\n" not in str(e.value)


def test_simulate_and_write_of_a_floating_model(floating_exo, tmp_path):
    """simulate_and_write's floating branch runs the one simulate: its file holds the gait twin's recording."""
    path = tmp_path / "gait.csv"
    outputs = Outputs(command="pinid simulate --base floating")
    floating = BaseSensors(noise=NOISE, rate=200.0)
    text = simulate_and_write(floating_exo, "gait", path, seconds=1.0, seed=2, floating=floating, outputs=outputs)
    assert text.startswith("simulated gait exo_lower_body on a floating base")
    old = simulate_gait(floating_exo, seconds=1.0, rate=200, noise=NOISE, seed=2)
    written = read_recording(path, model=floating_exo)
    for k, v in old.recording.floating.columns().items():
        np.testing.assert_allclose(written.floating.columns()[k], v, rtol=1e-9, atol=1e-12, err_msg=k)
    truth = json.loads(path.with_name("gait.truth.json").read_text())
    assert truth["command"] == "pinid simulate --base floating" and truth["seed"] == 2


@pytest.mark.parametrize("rate", [{"rates": Rates(integration=4000)}, {"integration_rate": 4000}])
def test_an_integration_rate_is_refused_for_a_floating_model(floating_exo, rate):
    """The floating twin computes the torques of a prescribed motion (inverse dynamics): no integration grid,
    so an integration rate is refused, not ignored."""
    with pytest.raises(SpecError, match=r"^integration rate: for a fixed-base model only"):
        simulate(floating_exo, "gait", seconds=0.5, **rate)
