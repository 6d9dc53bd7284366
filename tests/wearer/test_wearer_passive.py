"""Passive joint moments of the wearer (Riener & Edrich 1999) as a joint term."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from pinid.model.base import base_parameters
from pinid.model.regressor import parameter_names, regressor, standard_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.wearer import passive


def test_coefficients_have_their_source():
    table = passive.coefficients()
    assert "Riener" in table["source"]["citation"]
    for joint in passive.ANATOMICAL:
        assert table[joint]["source"].startswith("Riener & Edrich 1999")
        assert all(len(t["c"]) == 4 for t in table[joint]["terms"])


def test_moments_behave_like_tissue():
    # stiff at the ends of the range, pushing back towards a rest angle inside it
    assert passive.moment("hip", -20, 0, 0) > 20 and passive.moment("hip", 90, 0, 0) < -40
    assert passive.moment("knee", 0, 0, 0) > 5 and passive.moment("knee", 0, 120, 0) < -10
    rest = [a for a in np.linspace(-10, 80, 901) if abs(passive.moment("hip", a, 0, 0)) < 0.15]
    assert rest and 15 < np.mean(rest) < 35
    # two-joint muscle: flexing the hip stretches the hamstrings -> more knee flexion moment
    assert passive.moment("knee", 60, 30, 0) > passive.moment("knee", 0, 30, 0)


def test_exo_leg_mapping_and_regressor_identity():
    robot = RobotModel.from_urdf("exo_leg")
    assert passive.anatomy(robot) == [("hip", 1.0), ("knee", -1.0)]
    terms = TermSelection.from_names("fc,fv,passive")
    rng = np.random.default_rng(0)
    q = rng.uniform([-0.05, -1.6], [1.3, -0.1], (50, 2))
    dq, ddq = rng.normal(size=(50, 2)), rng.normal(size=(50, 2))
    theta = standard_parameters(robot, terms)
    names = base_parameters(robot, terms).names
    assert "hip.kp" in names and "knee.kp" in names
    tau = (regressor(robot, q, dq, ddq, terms) @ theta).reshape(50, 2)
    want = np.array([pin.rnea(robot.pin_model, robot.pin_model.createData(), q[k], dq[k], ddq[k]) for k in range(50)])
    want += robot.coulomb * np.sign(dq) + robot.viscous * dq - passive.passive_torque(q, robot)
    np.testing.assert_allclose(tau, want, atol=1e-9)
    # knee flexion is negative on exo_leg: its anatomical knee angle is -q
    M = passive.moment("knee", np.degrees(q[:, 0]), np.degrees(-q[:, 1]), 0)
    np.testing.assert_allclose(passive.passive_torque(q, robot)[:, 1], -M)


def test_scale_factors_recovered_by_least_squares():
    robot = RobotModel.from_urdf("exo_leg")
    terms = TermSelection.from_names("fc,fv,passive")
    rng = np.random.default_rng(1)
    q = rng.uniform([-0.05, -1.6], [1.3, -0.1], (200, 2))
    dq, ddq = rng.normal(size=(200, 2)), rng.normal(size=(200, 2))
    theta = standard_parameters(robot, terms)
    names = parameter_names(robot, terms)
    theta[names.index("hip.kp")], theta[names.index("knee.kp")] = 0.7, 1.4
    W = regressor(robot, q, dq, ddq, terms)
    bp = base_parameters(robot, terms)
    x, *_ = np.linalg.lstsq(bp.columns(W), W @ theta, rcond=None)
    got = dict(zip(bp.names, x))
    assert got["hip.kp"] == pytest.approx(0.7, rel=1e-9) and got["knee.kp"] == pytest.approx(1.4, rel=1e-9)
