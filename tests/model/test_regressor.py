"""Regressor × standard parameters equals Pinocchio's RNEA plus joint terms; base parameters reproduce it."""

from __future__ import annotations

import numpy as np
import pytest

from pinid import TermSelection, base_parameters, joint_torque, parameter_names, regressor, standard_parameters
from pinid.errors import DataError

from conftest import load

ROBOTS = ["exo_leg", "apal_leg", "ur5", "panda", "double_pendulum"]
ALL_TERMS = TermSelection(coulomb=True, viscous=True, offset=True, armature=True)


def _friction(model, dq, ddq, theta_joint, terms):
    cols = {"fc": np.sign(dq), "fv": dq, "offset": np.ones_like(dq), "armature": ddq}
    values = theta_joint.reshape(model.nv, len(terms))
    return sum(cols[t] * values[:, i] for i, t in enumerate(terms.names))


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("terms", [TermSelection(), ALL_TERMS], ids=["fc-fv", "all"])
def test_regressor_times_parameters_is_rnea_plus_joint_terms(name, terms):
    model = load(name)
    rng = np.random.default_rng(1)
    q, dq, ddq = model.random_states(25, rng)
    theta = standard_parameters(model, terms)
    theta[10 * model.nv :] = rng.uniform(0.1, 2.0, size=model.nv * len(terms))  # non-trivial joint terms
    tau = joint_torque(model, q, dq, ddq, theta, terms)
    expected = model.rnea(q, dq, ddq) + _friction(model, dq, ddq, theta[10 * model.nv :], terms)
    np.testing.assert_allclose(tau, expected, atol=1e-9, rtol=0)


@pytest.mark.parametrize("name", ROBOTS)
def test_base_parameters_reproduce_torques_on_fresh_states(name):
    model = load(name)
    terms = ALL_TERMS
    bp = base_parameters(model, terms)
    rng = np.random.default_rng(7)
    theta = standard_parameters(model, terms) + rng.normal(scale=0.1, size=len(bp.standard_names))
    q, dq, ddq = model.random_states(40, rng)
    W = regressor(model, q, dq, ddq, terms)
    np.testing.assert_allclose(bp.columns(W) @ bp.from_standard(theta), W @ theta, atol=1e-9)
    # the base regressor has full column rank
    assert np.linalg.matrix_rank(bp.columns(W)) == bp.count


def test_planar_two_link_leg_has_six_inertial_base_parameters():
    for name in ("exo_leg", "apal_leg", "double_pendulum"):
        bp = base_parameters(load(name), TermSelection())
        inertial = [n for n in bp.names if n.split(".")[1].rstrip("R") not in ("fc", "fv")]
        assert len(inertial) == 6, (name, bp.names)
        assert bp.count == 6 + 2 * 2


def test_base_parameters_are_deterministic():
    model = load("panda")
    a, b = base_parameters(model), base_parameters(model)
    np.testing.assert_array_equal(a.independent, b.independent)
    np.testing.assert_array_equal(a.P, b.P)
    assert a.expressions() == b.expressions()


def test_known_regrouping_of_the_planar_leg():
    """Khalil's regrouping: the knee link's mass folds into the hip's first moment and inertia."""
    model = load("exo_leg")
    bp = base_parameters(model)
    knee_origin = model.pin_model.jointPlacements[2].translation
    L = float(np.linalg.norm(knee_origin))
    exprs = dict(zip(bp.names, bp.expressions()))
    hip_moment = [e for n, e in exprs.items() if n.startswith("hip.m") and "knee.m" in e]
    assert hip_moment, exprs
    assert f"{L:.6g}·knee.m" in hip_moment[0]


def test_base_parameters_round_trip_json(tmp_path):
    from pinid import BaseParameters

    bp = base_parameters(load("exo_leg"))
    bp.save(tmp_path / "b.json")
    back = BaseParameters.load(tmp_path / "b.json")
    np.testing.assert_array_equal(back.independent, bp.independent)
    np.testing.assert_allclose(back.P, bp.P)
    assert back.names == bp.names


def test_parameter_names_follow_the_documented_order(exo):
    names = parameter_names(exo, ALL_TERMS)
    assert names[:10] == [f"hip.{p}" for p in ("m", "mx", "my", "mz", "Ixx", "Ixy", "Iyy", "Ixz", "Iyz", "Izz")]
    assert names[20:] == [
        "hip.fc",
        "hip.fv",
        "hip.offset",
        "hip.armature",
        "knee.fc",
        "knee.fv",
        "knee.offset",
        "knee.armature",
    ]


def test_regressor_rejects_wrong_shapes(exo):
    with pytest.raises(DataError, match=r"expected \(N, 2\)"):
        regressor(exo, np.zeros((5, 3)), np.zeros((5, 3)), np.zeros((5, 3)))
    with pytest.raises(DataError, match="same number"):
        regressor(exo, np.zeros((5, 2)), np.zeros((4, 2)), np.zeros((5, 2)))


def test_joint_terms_from_names():
    assert TermSelection.from_names("fc,offset") == TermSelection(True, False, True, False)
    assert TermSelection.from_names("none").names == []
    with pytest.raises(ValueError, match="unknown term"):
        TermSelection.from_names("fc,stiction")
