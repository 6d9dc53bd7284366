"""Sigmoid friction of Gaz et al. 2019 (``fsig``, its shape the model setting ``sigmoid``): the twin simulates it,
regressor × parameters is its torque, a noise-free twin gives the amplitude and (``auto``) the shape back, a saved
model predicts the same, and on noisy data the fit reaches the noise floor (issue 34)."""

from __future__ import annotations

import functools
import json
import warnings

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli
from pinid import regressor
from pinid.identification.study import Study
from pinid.data.dataset import Dataset
from pinid.errors import SpecError
from pinid.identification.identified import IdentifiedModel
from pinid.identification.run import identify
from pinid.model import terms as T
from pinid.model.base import base_parameters
from pinid.model.robot import RobotModel
from pinid.model.serialize import robot_from_dict, robot_to_dict
from pinid.model.terms_sigmoid import read_shape, shape_from_text, shapes, sigmoid_column
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.twin import simulate

FSIG = [0.8, 0.5]  # amplitudes φ1 per joint [N·m]
SHAPE = {"hip": {"steepness": 30.0, "offset": 0.02}, "knee": {"steepness": 60.0, "offset": -0.01}}
VS = 1e-4  # the twin's Coulomb smoothing [rad/s]
SEL = T.TermSelection.from_names("fc,fv,fsig")


def model(shape=SHAPE) -> RobotModel:
    return RobotModel.from_urdf("exo_leg").with_setting("sigmoid", shape)


def twin(m: RobotModel, seed: int = 2, noise: float = 0.0, seconds: float = 6.0):
    """``(recording, true signals)`` of the twin with the sigmoid friction ``FSIG``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # zha2019-4 is faster than exo_leg's URDF limits: a DataWarning
        rec, truth = simulate(
            m,
            load_trajectory("zha2019-4", m),
            seconds=seconds,
            seed=seed,
            terms={"fsig": FSIG},
            torque_noise=noise,
            coulomb_velocity=VS,
        )
    return rec, truth["signals"]


@functools.cache
def _noise_free():
    """``twin(model())``, simulated once per test run for the tests that only read it."""
    return twin(model())


def truth_theta(m: RobotModel) -> np.ndarray:
    theta = np.concatenate([m.inertial_parameters(), T.nominal(m, SEL)])
    names = m.inertial_names + T.term_parameter_names(m, SEL)
    for j, joint in enumerate(m.joint_names):
        theta[names.index(f"{joint}.fsig")] = FSIG[j]
    return theta


def _dataset(s, source: str) -> Dataset:
    return Dataset(s.t, s.q, ["hip", "knee"], dq=s.dq, ddq=s.ddq, tau=s.tau, source=source)


def test_the_column_is_gaz_sigmoid_and_the_shape_is_a_saved_setting():
    dq = np.linspace(-1, 1, 11)
    a, b = 30.0, 0.02
    gaz = 1 / (1 + np.exp(-a * (dq + b))) - 1 / (1 + np.exp(-a * b))
    np.testing.assert_allclose(sigmoid_column(dq, a, b), gaz, atol=1e-15)
    assert sigmoid_column(0.0, a, b) == 0.0 and np.isfinite(sigmoid_column(1e6, 1e6, 0.0))
    plain = RobotModel.from_urdf("exo_leg")
    np.testing.assert_array_equal(shapes(plain), [[40.0, 0.0], [40.0, 0.0]])  # the default
    np.testing.assert_array_equal(shapes(plain.with_setting("sigmoid", "auto")), [[40.0, 0.0], [40.0, 0.0]])
    np.testing.assert_array_equal(shapes(model()), [[30.0, 0.02], [60.0, -0.01]])
    assert shape_from_text("50,0.01") == {"steepness": 50.0, "offset": 0.01}
    assert shape_from_text("hip=30:0.02,knee=60:-0.01") == SHAPE
    assert shape_from_text(" AUTO ") == "auto"
    for bad in ("50", "-3,0", "hip=30", "x,y"):
        with pytest.raises(SpecError, match="sigmoid-shape"):
            shape_from_text(bad)
    with pytest.raises(SpecError, match="steepness"):
        read_shape({"steepness": 0.0, "offset": 0.0}, "test")
    saved = robot_to_dict(model(), SEL)
    assert saved["sigmoid"] == SHAPE
    again = robot_from_dict(json.loads(json.dumps(saved)))[0]
    np.testing.assert_array_equal(shapes(again), shapes(model()))


def test_the_twin_simulates_it_and_ols_sdp_give_the_amplitude_back():
    m = model()
    _, s = _noise_free()
    law = T.torque(m, T.TermSelection(names=["fsig"]), np.asarray(FSIG), s.q, s.dq, s.ddq, smoothing=VS)
    want = m.rnea(s.q, s.dq, s.ddq) + m.coulomb * np.tanh(s.dq / VS) + m.viscous * s.dq + law
    np.testing.assert_allclose(s.tau, want, atol=1e-9 * np.abs(s.tau).max())
    assert np.sqrt(np.mean(law**2)) > 0.02 * np.sqrt(np.mean(s.tau**2))  # it matters
    theta = truth_theta(m)
    W = regressor(m, s.q, s.dq, s.ddq, SEL)
    far = (np.abs(s.dq) > 30 * VS).reshape(-1)
    np.testing.assert_allclose((W @ theta)[far], s.tau.reshape(-1)[far], atol=1e-9 * np.abs(s.tau).max())
    truth = base_parameters(m, SEL).from_standard(theta)
    ident = identify(Study(m, _dataset(s, "twin-fsig"), terms=SEL, rest_velocity=30 * VS), methods=["ols", "sdp"])
    for method in ("ols", "sdp"):
        rel = np.max(np.abs(ident[method].base - truth) / np.maximum(np.abs(truth), 1e-3))
        assert rel <= 1e-6, method
        found = ident[method].model.standard_parameters
        np.testing.assert_allclose([found[f"{j}.fsig"] for j in m.joint_names], FSIG, rtol=1e-6, err_msg=method)
    again = IdentifiedModel.from_dict(json.loads(json.dumps(ident.model.to_dict())))
    rows = far.reshape(s.q.shape).all(axis=1)
    np.testing.assert_allclose(
        again.inverse_dynamics(s.q, s.dq, s.ddq)[rows], s.tau[rows], atol=1e-6 * np.abs(s.tau).max()
    )
    np.testing.assert_allclose(
        again.inverse_dynamics(s.q, s.dq, s.ddq), ident.model.inverse_dynamics(s.q, s.dq, s.ddq), atol=1e-12
    )


def test_auto_fits_the_shape_back_on_noise_free_data():
    m = model()
    _, s = _noise_free()
    start = model("auto")
    ident = identify(Study(start, _dataset(s, "twin-fsig"), terms=SEL, rest_velocity=30 * VS), methods=["ols"])
    got = shapes(ident["ols"].model.robot)
    np.testing.assert_allclose(got[:, 0], [30.0, 60.0], rtol=1e-4)
    np.testing.assert_allclose(got[:, 1], [0.02, -0.01], atol=1e-6)
    summary = ident.data["sigmoid"]
    assert summary["fitted"] and all(v["fitted"] for v in summary["per_joint"].values())
    found = ident["ols"].model.standard_parameters
    np.testing.assert_allclose([found[f"{j}.fsig"] for j in m.joint_names], FSIG, rtol=1e-4)


@pytest.mark.filterwarnings("ignore:.*repeats the trajectory")  # one excitation, two noise draws: the point here
@pytest.mark.slow  # 3–4.5 s on a quiet 2-core machine: the quick run (-m "not slow") stays within 3 min
def test_on_noisy_data_the_validation_rms_reaches_the_noise_floor():
    m = model()
    sets = []
    for seed, seconds in ((3, 8.0), (4, 6.0)):  # the true motion, the torque as recorded (noisy)
        rec, s = twin(m, seed=seed, noise=0.3, seconds=seconds)
        sets.append(Dataset(s.t, s.q, ["hip", "knee"], dq=s.dq, ddq=s.ddq, tau=rec.tau, source=f"noisy-{seed}"))
    train, val = sets
    ident = identify(
        Study(model("auto"), train, validate=val, terms=SEL, rest_velocity=30 * VS), methods=["ols", "sdp"]
    )
    true = IdentifiedModel(m, SEL, truth_theta(m)).inverse_dynamics(val.q, val.dq, val.ddq)
    floor = float(np.sqrt(np.mean((true - val.tau) ** 2)))
    assert 0.25 < floor < 0.35
    for method in ("ols", "sdp"):
        got = ident[method].validation.all["rms"]
        assert got <= 1.05 * floor, (method, got, floor)


def test_cli_takes_fsig_and_the_shape_and_refuses_a_bad_shape(recording, tmp_path):
    out = tmp_path / "s"
    p = run_cli(
        "identify", "--urdf", "exo_leg", "--data", str(recording), "--methods", "ols",
        "--terms", "fc,fv,fsig", "--sigmoid-shape", "25,0.01", "-o", str(out), "--no-report",
    )  # fmt: skip
    assert p.returncode == 0, p.stderr
    saved = json.loads((out / "identification.json").read_text())
    assert saved["robot"]["sigmoid"] == {"steepness": 25.0, "offset": 0.01}
    p = run_cli(
        "identify", "--urdf", "exo_leg", "--data", str(recording), "--methods", "ols",
        "--terms", "fc,fv,fsig", "--sigmoid-shape", "-1,0", "-o", str(tmp_path / "b"), "--no-report",
    )  # fmt: skip
    assert_clean_error(p, "sigmoid-shape")
