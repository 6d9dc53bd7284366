"""The twin with a wearer: every registered joint term acts in the plant; the wearer's active torque."""

from __future__ import annotations

import json

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli
from pinid.errors import DataWarning
from pinid.errors import SpecError
from pinid.model import terms as T
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.twin import Friction, WearerLoad, simulate
from pinid.wearer.attach import wearer_links, wearer_urdf


@pytest.fixture(scope="module")
def worn(tmp_path_factory):
    path = tmp_path_factory.mktemp("w") / "exo_with_wearer.urdf"
    wearer_urdf("exo_leg", "hip:thigh,knee:shank,knee:foot", mass=75, height=1.78, sex="male", path=path)
    return path, RobotModel.from_urdf(path)


def _residual(m, truth, vs=0.01, extra=None):
    """tau − (rnea + tanh Coulomb + viscous + the extra terms' plant laws) at the true samples, (N, nv)."""
    s = truth["signals"]
    tau = m.rnea(s.q, s.dq, s.ddq) + m.coulomb * np.tanh(s.dq / vs) + m.viscous * s.dq
    for name, v in (extra or {}).items():
        tau += T.torque(m, TermSelection.from_names(name), np.asarray(v, float), s.q, s.dq, s.ddq, smoothing=vs)
    return s.tau - tau


def test_wearer_twin_applies_passive_moments(worn):
    _, m = worn
    with pytest.warns(DataWarning, match="above its URDF velocity limit"):  # zha2019-2 is faster than exo_leg allows
        _, truth = simulate(
            m,
            load_trajectory("zha2019-2", m),
            seconds=1.0,
            seed=2,
            torque_noise=0.0,
            wearer=WearerLoad(wearer_links(m.urdf_text)),
        )
    assert truth["terms"] == ["fc", "fv", "passive"]
    assert truth["wearer"]["terms"] == {"passive": {"hip": 1.0, "knee": 1.0}}
    i = truth["standard"]["names"].index("knee.kp")
    assert truth["standard"]["values"][i] == 1.0
    assert np.max(np.abs(_residual(m, truth, extra={"passive": [1.0, 1.0]}))) < 1e-8
    assert np.max(np.abs(_residual(m, truth))) > 0.5  # the passive moment is there (N·m near the knee's end)


def test_every_registered_joint_term_acts_through_its_law(exo):
    extra = {"fc_pos": [0.6, 0.4], "fc_neg": [0.3, 0.2], "offset": [0.5, -0.7]}
    with pytest.warns(DataWarning, match="above its URDF velocity limit"):  # zha2019-2 is faster than exo_leg allows
        _, truth = simulate(exo, load_trajectory("zha2019-2", exo), seconds=1.0, seed=2, terms=extra, torque_noise=0.0)
        group = Friction(terms=extra)  # terms= is the keyword form of the Friction group's terms
        _, same = simulate(
            exo, load_trajectory("zha2019-2", exo), seconds=1.0, seed=2, friction=group, torque_noise=0.0
        )
    assert np.max(np.abs(_residual(exo, truth, extra=extra))) < 1e-8
    np.testing.assert_array_equal(same["signals"].tau, truth["signals"].tau)
    names = truth["standard"]["names"]
    assert truth["standard"]["values"][names.index("knee.fc_pos")] == 0.4
    with pytest.raises(SpecError, match="plant term 'fc'"):
        simulate(exo, load_trajectory("zha2019-2", exo), seconds=1.0, terms={"fc": [1, 1]})


def test_active_wearer_torque_has_its_rms_and_is_not_recorded(worn):
    _, m = worn
    with pytest.warns(DataWarning, match="above its URDF velocity limit"):  # zha2019-2 is faster than exo_leg allows
        _, truth = simulate(
            m,
            load_trajectory("zha2019-2", m),
            seconds=2.0,
            seed=3,
            torque_noise=0.0,
            wearer=WearerLoad(wearer_links(m.urdf_text), torque=5.0),
        )
    rms = np.array(list(truth["wearer"]["active_torque"]["rms"].values()))
    s = truth["signals"]
    g_rms = np.sqrt(np.mean(m.rnea(s.q, 0 * s.q, 0 * s.q) ** 2, axis=0))
    np.testing.assert_allclose(rms, 0.05 * g_rms, rtol=0.05)  # gravity along the desired vs the tracked path
    res = _residual(m, truth, extra={"passive": [1.0, 1.0]})  # = −disturbance at the samples
    np.testing.assert_allclose(np.sqrt(np.mean(res**2, axis=0)), rms, rtol=0.02)
    assert np.all(np.abs(np.diff(res, axis=0)).max(axis=0) < 0.05 * rms)  # smooth: 0.2–2 Hz


def test_cli_wearer_draw_and_torque(worn, tmp_path):
    path, _ = worn
    out = tmp_path / "w.csv"
    p = run_cli(
        "simulate",
        "--urdf",
        str(path),
        "--excitation",
        "zha2019-2",
        "--seconds",
        "0.5",
        "--wearer-draw",
        "--wearer-torque",
        "5",
        "-o",
        str(out),
    )
    assert p.returncode == 0, p.stderr
    w = json.loads(out.with_name("w.truth.json").read_text())["wearer"]
    assert w["active_torque"]["percent_of_gravity_rms"] == 5.0
    table = sum(seg["mass"] for seg in w["table_segments"].values() if seg["link"] == "shank")
    drawn = w["drawn"]["wearer_standard"]["knee"][0]
    assert drawn != table and abs(drawn / table - 1) <= 0.25
    p = run_cli(
        "simulate",
        "--urdf",
        "exo_leg",
        "--excitation",
        "zha2019-2",
        "--seconds",
        "0.5",
        "--wearer-draw",
        "-o",
        str(tmp_path / "x.csv"),
    )
    assert_clean_error(p, "exo_leg carries no wearer to draw")
    assert not list(tmp_path.glob("x*"))


def test_model_with_passive_terms_for_control(worn):
    """The passive moment depends on q only: a model's gravity(q) includes it, its friction(dq) does not."""
    from pinid.identification.identified import IdentifiedModel
    from pinid.model.regressor import standard_parameters

    _, m = worn
    terms = TermSelection.from_names("fv,passive")
    model = IdentifiedModel(m, terms, standard_parameters(m, terms))
    q, dq = np.array([0.9, -1.5]), np.array([0.3, -0.2])
    np.testing.assert_allclose(model.friction(dq), m.viscous * dq)
    expected = (
        m.rnea(q[None], 0 * q[None], 0 * q[None])[0]
        + T.torque(m, TermSelection.from_names("passive"), np.ones(2), q[None], 0 * q[None], 0 * q[None])[0]
    )
    np.testing.assert_allclose(model.gravity(q), expected, atol=1e-12)
    np.testing.assert_allclose(
        model.inverse_dynamics(q, dq, 0 * q),
        model.gravity(q) + model.coriolis(q, dq) @ dq + model.friction(dq),
        atol=1e-10,
    )


@pytest.mark.slow  # 4.4 s of CPU (docs/benchmarks.md, Test suite)
def test_track_plant_carries_the_wearer(worn):
    """pinid.control's plant applies the passive moments: a model without them tracks worse than with them."""
    from pinid.control.tracking import sine_reference
    from pinid.control.controllers import ComputedTorque, Tracking, nominal_model, track
    from pinid.identification.identified import IdentifiedModel
    from pinid.model.regressor import standard_parameters

    _, m = worn
    terms = TermSelection.from_names("fc,fv,passive")
    full = IdentifiedModel(m, terms, standard_parameters(m, terms))
    ref = sine_reference(m)
    worn_by = wearer_links(m.urdf_text)  # the plant's wearer, handed to the twin
    e_full = track(m, ComputedTorque(full), ref, Tracking(2.0), wearer=worn_by).metrics(after=1.0)
    e_rigid = track(m, ComputedTorque(nominal_model(m)), ref, Tracking(2.0), wearer=worn_by).metrics(after=1.0)
    assert all(e_rigid[j]["rms"] > 100 * e_full[j]["rms"] for j in m.joint_names)
