"""Position ripple (``ripple_s1`` … ``ripple_c3``, group ``ripple``) and load-dependent Coulomb friction (``fl``):
the twin simulates each, its recording satisfies regressor × parameters, and a noise-free twin gives the
true values back (issue 34)."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli
from pinid import regressor
from pinid.identification.study import Study
from pinid.data.dataset import Dataset
from pinid.errors import ModelError, SpecError
from pinid.identification.identified import IdentifiedModel
from pinid.identification.run import identify
from pinid.model import terms as T
from pinid.model.base import base_parameters
from pinid.model.robot import RobotModel
from pinid.model.serialize import robot_from_dict, robot_to_dict
from pinid.model.terms_ripple import periods
from pinid.simulation.trajectories import load_trajectory
from pinid.simulation.twin import simulate

RIPPLE = {"ripple_s1": [0.3, -0.2], "ripple_c1": [-0.15, 0.25], "ripple_s2": [0.08, 0.05], "ripple_c2": [0.04, -0.06]}
FL = [0.06, 0.09]  # load-dependent Coulomb per joint (dimensionless)
VS = 1e-4  # the twin's Coulomb smoothing [rad/s]: tanh(dq/VS) is sign(dq) above 30·VS


def model() -> RobotModel:
    return RobotModel.from_urdf("exo_leg").with_setting("ripple_periods", {"hip": 9.0, "knee": 13.0})


def twin(m: RobotModel, terms: dict, seconds: float = 6.0):
    """The twin's true signals (noise free; its Coulomb friction that of the URDF, smoothed by VS)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # zha2019-4 is faster than exo_leg's URDF limits: a DataWarning
        _, truth = simulate(
            m,
            load_trajectory("zha2019-4", m),
            seconds=seconds,
            seed=2,
            terms=terms,
            torque_noise=0.0,
            coulomb_velocity=VS,
        )
    return truth["signals"]


def truth_theta(m: RobotModel, sel: T.TermSelection, terms: dict) -> np.ndarray:
    theta = np.concatenate([m.inertial_parameters(), T.nominal(m, sel)])
    names = m.inertial_names + T.term_parameter_names(m, sel)
    for name, v in terms.items():
        for j, joint in enumerate(m.joint_names):
            theta[names.index(f"{joint}.{T.TERMS[name].suffix}")] = v[j]
    for j, joint in enumerate(m.joint_names):
        theta[names.index(f"{joint}.fv")], theta[names.index(f"{joint}.fc")] = m.viscous[j], m.coulomb[j]
    return theta


def _relative(a, b):
    return np.max(np.abs(a - b) / np.maximum(np.abs(b), 1e-3))


def test_the_group_names_the_harmonics_and_the_periods_come_from_setting_or_drives():
    assert T.TermSelection.from_names("fc,ripple").names == ["fc", "ripple_s1", "ripple_c1"]
    assert T.TermSelection.from_names("ripple2").names == ["ripple_s1", "ripple_c1", "ripple_s2", "ripple_c2"]
    assert len(T.TermSelection.from_names("ripple3")) == 6
    m = RobotModel.from_urdf("exo_leg")
    with pytest.raises(ModelError, match="ripple-periods"):
        periods(m)
    np.testing.assert_array_equal(periods(m.with_setting("ripple_periods", 50)), [50.0, 50.0])
    np.testing.assert_array_equal(periods(model()), [9.0, 13.0])
    with pytest.raises(ModelError, match="not joints"):
        periods(m.with_setting("ripple_periods", {"elbow": 3.0}))
    with pytest.raises(SpecError, match="> 0"):
        T.TERMS["ripple_s1"].read_setting(-2, "test")
    from test_terms_contract import robot as coupled  # drives G = [[30, 0], [12, 25]]

    np.testing.assert_array_equal(periods(coupled()), [30.0, 25.0])  # the motor turning each joint most
    saved = robot_to_dict(model(), T.TermSelection.from_names("ripple"))
    assert saved["ripple_periods"] == {"hip": 9.0, "knee": 13.0}
    assert robot_from_dict(json.loads(json.dumps(saved)))[0].setting("ripple_periods") == {"hip": 9.0, "knee": 13.0}


@pytest.mark.parametrize("case", ["ripple", pytest.param("fl", marks=pytest.mark.slow)])  # fl: 4 s
def test_the_twin_simulates_the_term_and_identification_gives_it_back(case):
    m = model()
    terms = RIPPLE if case == "ripple" else {"fl": FL}
    sel = T.TermSelection.from_names("fc,fv,ripple2" if case == "ripple" else "fc,fv,fl")
    s = twin(m, terms)
    # the twin's torque is rigid body + friction + the term's plant law …
    law = sum(
        T.torque(m, T.TermSelection(names=[n]), np.asarray(v), s.q, s.dq, s.ddq, smoothing=VS) for n, v in terms.items()
    )
    want = m.rnea(s.q, s.dq, s.ddq) + m.coulomb * np.tanh(s.dq / VS) + m.viscous * s.dq + law
    np.testing.assert_allclose(s.tau, want, atol=1e-9 * np.abs(s.tau).max())
    assert np.sqrt(np.mean(law**2)) > 0.02 * np.sqrt(np.mean(s.tau**2))  # it matters
    # … and regressor × parameters away from the Coulomb smoothing (|dq| > 30·VS)
    theta = truth_theta(m, sel, terms)
    W = regressor(m, s.q, s.dq, s.ddq, sel)
    far = (np.abs(s.dq) > 30 * VS).reshape(-1)
    np.testing.assert_allclose((W @ theta)[far], s.tau.reshape(-1)[far], atol=1e-9 * np.abs(s.tau).max())
    # the noise-free twin gives the values back (rows within 30·VS of rest left out: fc is in the model)
    ds = Dataset(s.t, s.q, m.joint_names, dq=s.dq, ddq=s.ddq, tau=s.tau, source=f"twin-{case}")
    truth = base_parameters(m, sel).from_standard(theta)
    ident = identify(Study(m, ds, terms=sel, rest_velocity=30 * VS), methods=["ols", "sdp"])
    for method in ("ols", "sdp"):
        assert _relative(ident[method].base, truth) <= 1e-6, method
        found = ident[method].model.standard_parameters
        for name, v in terms.items():
            got = [found[f"{j}.{T.TERMS[name].suffix}"] for j in m.joint_names]
            np.testing.assert_allclose(got, v, rtol=1e-6, err_msg=f"{method} {name}")
    # the identified model predicts with the nominal load torque and the saved periods
    again = IdentifiedModel.from_dict(json.loads(json.dumps(ident.model.to_dict())))
    np.testing.assert_allclose(
        again.inverse_dynamics(s.q, s.dq, s.ddq)[far.reshape(s.q.shape).all(axis=1)],
        s.tau[far.reshape(s.q.shape).all(axis=1)],
        atol=1e-6 * np.abs(s.tau).max(),
    )


def test_friction_of_the_identified_model_leaves_the_load_term_out_and_gravity_has_the_ripple():
    m = model()
    sel = T.TermSelection.from_names("fc,fv,ripple,fl")
    theta = np.concatenate([m.inertial_parameters(), np.ones(T.term_count(m, sel))])
    im = IdentifiedModel(m, sel, theta)
    dq = np.array([0.3, -0.4])
    np.testing.assert_allclose(im.friction(dq), np.sign(dq) + dq)
    q = np.array([0.2, -0.5])
    g = m.rnea(q, 0 * q, 0 * q)
    np.testing.assert_allclose(im.gravity(q), g + np.sin(periods(m) * q) + np.cos(periods(m) * q), atol=1e-9)


def test_cli_ripple_periods_reach_the_saved_model_and_bad_ones_are_refused(recording, tmp_path):
    out = tmp_path / "r"

    def identify(*args: str):  # pinid identify of the ripple terms on the recording
        return run_cli("identify", "--urdf", "exo_leg", "--data", str(recording), "--terms", "fc,fv,ripple", *args)

    p = identify("--ripple-periods", "hip=9,knee=13", "--methods", "ols", "--no-report", "-o", str(out))
    assert p.returncode == 0, p.stderr
    saved = json.loads((out / "model_ols.json").read_text())
    assert saved["robot"]["ripple_periods"] == {"hip": 9.0, "knee": 13.0}
    assert "hip.ripple_s1" in json.dumps(saved)
    p = identify("--ripple-periods", "-3", "-o", str(tmp_path / "x"))
    assert_clean_error(p, "--ripple-periods", "> 0")
    p = identify("-o", str(tmp_path / "y"))
    assert_clean_error(p, "ripple periods", "--ripple-periods")
