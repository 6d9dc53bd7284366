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


# ---------------------------------------------------------------- a floating model: dispatched on (issue 32)
FLOATING = ["exo_lower_body", "solo12", "double_pendulum_continuous"]


def _floating(name):
    from pinid import RobotModel

    if name == "double_pendulum_continuous":  # continuous joints: Pinocchio's cos, sin in the free-flyer q
        return RobotModel.from_urdf(load("double_pendulum").urdf_path.with_name(name + ".urdf"), base="floating")
    return RobotModel.from_urdf(name, base="floating")


@pytest.mark.parametrize("name", FLOATING)
def test_floating_model_gives_the_free_flyers_pinocchio_numbers(name):
    """parameter_names / standard_parameters / regressor of a FloatingRobotModel are the free flyer's, computed
    here with Pinocchio directly: the base body first, the inertial block equal to computeJointTorqueRegressor on
    ff_model bit for bit, W·θ equal to pin.rnea (base wrench, joint torques), friction in the joint rows only."""
    import pinocchio as pin

    from pinid.model.floating import random_floating_states

    model = _floating(name)
    terms = TermSelection.from_names("fc,fv")
    n, nv, ff = 9, model.nv, model.ff_model
    names = parameter_names(model, terms)
    inertial = [f"{b}.{p}" for b in ["base", *model.joint_names] for p in ("m", "mx", "my", "mz")]
    assert [x for x in names if x.split(".")[1] in ("m", "mx", "my", "mz")] == inertial
    assert names[10 * (nv + 1) :] == [f"{b}.{t}" for b in ["base", *model.joint_names] for t in ("fc", "fv")]
    theta = standard_parameters(model, terms)
    direct = np.concatenate([ff.inertias[i].toDynamicParameters() for i in range(1, ff.njoints)])
    assert np.array_equal(theta[: 10 * (nv + 1)], direct) and len(theta) == len(names)
    rng = np.random.default_rng(2)
    theta[10 * (nv + 1) :] = rng.uniform(0.1, 2.0, 2 * (nv + 1))  # friction values, the base's too (no column)
    Q, V, A = model.full_state(*random_floating_states(model, n, rng))
    assert Q.shape == (n, ff.nq) and V.shape == A.shape == (n, 6 + nv)
    W = regressor(model, Q, V, A, terms).reshape(n, 6 + nv, -1)
    data = ff.createData()
    for k in range(n):
        assert np.array_equal(W[k, :, : 10 * (nv + 1)], pin.computeJointTorqueRegressor(ff, data, Q[k], V[k], A[k]))
    rnea = np.array([pin.rnea(ff, data, Q[k], V[k], A[k]) for k in range(n)])
    fc, fv = theta[10 * (nv + 1) + 2 :: 2], theta[10 * (nv + 1) + 3 :: 2]
    friction = fc * np.sign(V[:, 6:]) + fv * V[:, 6:]
    tau = W @ theta
    assert np.abs(tau - np.hstack([rnea[:, :6], rnea[:, 6:] + friction])).max() <= 1e-9 * max(1, np.abs(rnea).max())
    assert np.abs(rnea[:, :6]).max() > 1.0  # the base rows carry signal
    np.testing.assert_allclose(joint_torque(model, Q, V, A, theta, terms), tau, rtol=0, atol=1e-12)


def test_floating_regressor_refuses_joint_states_naming_the_free_flyer_shape():
    model = _floating("exo_lower_body")
    q, dq, ddq = model.random_states(4, np.random.default_rng(0))
    with pytest.raises(DataError, match=r"q: shape \(4, 8\), expected \(N, 15\) for the floating .*full_state") as e:
        regressor(model, q, dq, ddq)
    assert "\n" not in str(e.value)
    Q, V, A = model.full_state(np.tile([0, 0, 0, 0, 0, 0, 1.0], (4, 1)), np.zeros((4, 6)), np.zeros((4, 6)), q, dq, ddq)
    with pytest.raises(DataError, match=r"ddq: shape \(4, 8\), expected \(N, 14\)"):
        regressor(model, Q, V, ddq)
    Q[2, 3:7] *= 1.5
    with pytest.raises(DataError, match="q: base quaternion of sample 2 has norm"):
        regressor(model, Q, V, A)


@pytest.mark.parametrize("name", ["exo_lower_body", "solo12"])
def test_fixed_model_and_the_fixed_base_view_are_unchanged(name):
    """A fixed-base model's regressor is Pinocchio's on its model (joint rows only); a floating model's
    ``fixed_base`` (the base held still) gives exactly the fixed-base robot's names, values and regressor."""
    import pinocchio as pin

    from pinid import RobotModel

    fixed, floating = RobotModel.from_urdf(name), _floating(name)
    view = floating.fixed_base
    assert type(view) is RobotModel and view is floating.fixed_base  # built once
    terms = TermSelection.from_names("fc,fv")
    q, dq, ddq = fixed.random_states(6, np.random.default_rng(5))
    W = regressor(fixed, q, dq, ddq, terms)
    assert np.array_equal(W, regressor(view, q, dq, ddq, terms))
    assert (
        parameter_names(view, terms)
        == parameter_names(fixed, terms)
        == fixed.inertial_names + [f"{j}.{t}" for j in fixed.joint_names for t in ("fc", "fv")]
    )
    assert np.array_equal(standard_parameters(view, terms), standard_parameters(fixed, terms))
    data = fixed.pin_model.createData()
    for k in range(6):
        ref = pin.computeJointTorqueRegressor(fixed.pin_model, data, q[k], dq[k], ddq[k])
        assert np.array_equal(W.reshape(6, fixed.nv, -1)[k, :, : 10 * fixed.nv], ref)
