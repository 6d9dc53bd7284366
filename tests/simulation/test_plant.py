"""The twin's plant (pinid.simulation.plant): its step gives, to the last bit, the numbers of the step as it was
written before it was made cheaper (the twin's recordings, and every figure made from them, stay the same)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from pinid.simulation.plant import Plant

from conftest import load


def reference_step(plant: Plant, vs: float, q, v, tau, h):
    """The step of a plant with joint friction only, as written in 89c20de (pinid/simulation/twin.py)."""
    pm = plant.model.pin_model
    data = pm.createData()
    nle = pin.nonLinearEffects(pm, data, q, v)
    th = np.tanh(v * (1.0 / vs))
    Dx = 0.0
    Minv = pin.computeMinverse(pm, data, q)
    a = Minv @ (tau - nle - plant.fc * th - plant.fv * v)
    D = plant.fc * (1.0 / vs) * (1.0 - th * th) + plant.fv + Dx
    stiff = h * float((Minv.diagonal() * D).max()) > 0.1
    D = np.diag(D) if stiff else D
    dv = np.linalg.solve(np.eye(len(q)) + (h * Minv) @ D, h * a) if stiff else h * a
    v_new = v + dv
    return a, q + (0.5 * h) * (v + v_new), v_new, stiff


@pytest.mark.parametrize("name", ["exo_leg", "ur5"])
def test_the_step_is_the_former_step_bit_for_bit(name):
    robot = load(name)
    plant = Plant(robot, robot.coulomb + 0.5, robot.viscous + 0.1, 0.01)
    rng = np.random.default_rng(1)
    stiff = 0
    for k in range(200):
        q = rng.uniform(-0.8, 0.8, robot.nv)
        v = rng.uniform(-2.0, 2.0, robot.nv) * (1e-3 if k % 2 else 1.0)  # half near zero velocity
        tau = rng.uniform(-20.0, 20.0, robot.nv)
        for h in (5e-4, 2.5e-4):
            *want, implicit = reference_step(plant, 0.01, q, v, tau, h)
            got = plant.step(q, v, tau, h)
            assert all(np.array_equal(x, y) for x, y in zip(got, want)), (q, v, tau, h)
            stiff += implicit
    assert 0 < stiff < 400  # both friction branches compared
