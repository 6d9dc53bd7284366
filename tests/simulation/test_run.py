"""``simulate_and_write``: one call whatever the base (issue 32), dispatching on the model; the option groups
of the other base are refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import load
from pinid.data.formats import read_recording
from pinid.errors import SpecError
from pinid.simulation.floating_twin import BaseSensors, Noise
from pinid.simulation.run import FixedBase, Outputs, simulate_and_write
from pinid.simulation.twin import Rates, Sensors, WearerLoad


def test_fixed_base_groups_reach_the_twin(tmp_path):
    """The rates, sensors, CAD perturbation and outputs given as groups are the ones the run records."""
    fixed = FixedBase(rates=Rates(500.0), sensors=Sensors(position_noise=0.0), perturb=10.0)
    out = Outputs(cad_urdf=tmp_path / "cad.urdf", command="pinid simulate test")
    text = simulate_and_write(
        load("exo_leg"), "exo_leg", tmp_path / "r.csv", seconds=1.0, seed=3, fixed=fixed, outputs=out
    )
    truth = json.loads((tmp_path / "r.truth.json").read_text())
    ds = read_recording(tmp_path / "r.csv")
    assert ds.n == 500 and np.allclose(np.diff(ds.t), 1 / 500)
    assert truth["cad"]["percent"] == 10.0 and truth["command"] == "pinid simulate test"
    assert (tmp_path / "cad.urdf").exists() and "r.csv" in text and not (tmp_path / "r.png").exists()


def test_floating_base_dispatches_to_the_floating_twin(floating_exo, tmp_path):
    """A FloatingRobotModel walks ("gait") at the BaseSensors' rate with their noise; the truth says so."""
    options = BaseSensors(noise=Noise(position=1e-4), rate=200.0)
    text = simulate_and_write(floating_exo, "gait", tmp_path / "g.csv", seconds=0.5, seed=1, floating=options)
    truth = json.loads((tmp_path / "g.truth.json").read_text())
    assert truth["base"] == "floating" and truth["kind"] == "gait" and truth["rate_hz"] == 200.0
    assert truth["noise"]["position"] == 1e-4 and truth["seconds"] == 0.5
    assert "floating base: 101 samples" in text


@pytest.mark.parametrize(
    "case, match",
    [
        ("floating group, fixed model", "floating: a BaseSensors is for a floating-base twin"),
        ("fixed group, floating model", "fixed: a FixedBase is for a fixed-base twin"),
        ("wearer, floating model", "wearer: a WearerLoad is for a fixed-base twin"),
        ("true signals, floating model", "outputs true_signals: written by a fixed-base twin only"),
        ("flip, floating model", "flip \\['hip'\\]"),
    ],
)
def test_a_group_for_the_other_base_is_refused(case, match, floating_exo, tmp_path):
    fixed, path = load("exo_leg"), tmp_path / "x.csv"
    calls = {
        "floating group, fixed model": lambda: simulate_and_write(fixed, "exo_leg", path, floating=BaseSensors()),
        "fixed group, floating model": lambda: simulate_and_write(floating_exo, "gait", path, fixed=FixedBase()),
        "wearer, floating model": lambda: simulate_and_write(floating_exo, "gait", path, wearer=WearerLoad()),
        "true signals, floating model": lambda: simulate_and_write(
            floating_exo, "gait", path, outputs=Outputs(true_signals=tmp_path / "s.csv")
        ),
        "flip, floating model": lambda: simulate_and_write(floating_exo, "gait", path, flip=["hip"]),
    }
    with pytest.raises(SpecError, match=match) as err:
        calls[case]()
    assert "\n" not in str(err.value) and not list(tmp_path.iterdir())


@pytest.mark.parametrize(
    "make, match",
    [
        (lambda: FixedBase(rates=500.0), "FixedBase rates: got float, expected a Rates or None"),
        (lambda: FixedBase(perturb="10"), "FixedBase perturb: got str"),
        (lambda: BaseSensors(noise=0.1), "BaseSensors noise: got float, expected a Noise"),
        (lambda: BaseSensors(rate="200"), "BaseSensors rate: got str, expected a rate"),
        (lambda: BaseSensors(imu_frame=3), "BaseSensors imu_frame: got int"),
        (lambda: Outputs(figure=3), "Outputs figure: got int, expected a path or None"),
    ],
)
def test_groups_refuse_wrong_types(make, match):
    with pytest.raises(SpecError, match=match):
        make()


def test_a_group_of_the_wrong_class_is_refused(tmp_path):
    with pytest.raises(SpecError, match="outputs: got dict, expected Outputs or None"):
        simulate_and_write(load("exo_leg"), "exo_leg", tmp_path / "x.csv", outputs={"figure": "f.png"})
