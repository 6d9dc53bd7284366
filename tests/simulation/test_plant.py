"""The twin's plant (pinid.simulation.plant): the lean step of a plant with joint friction only gives the
general step's numbers to the last bit, and is taken only where it applies."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from pinid.simulation.plant import Plant

from conftest import load


def _states(nv: int, n: int, seed: int):
    """Random (q, v, tau), half of them with velocities near zero (the implicit-friction branch)."""
    rng = np.random.default_rng(seed)
    for k in range(n):
        v = rng.uniform(-2.0, 2.0, nv) * (1e-3 if k % 2 else 1.0)
        yield rng.uniform(-0.8, 0.8, nv), v, rng.uniform(-20.0, 20.0, nv)


@pytest.mark.parametrize("name", ["exo_leg", "ur5"])
def test_lean_step_is_the_general_step_bit_for_bit(name):
    robot = load(name)
    lean = Plant(robot, robot.coulomb + 0.5, robot.viscous + 0.1, 0.01)
    general = Plant(robot, robot.coulomb + 0.5, robot.viscous + 0.1, 0.01)
    general._lean = False
    assert lean._lean
    stiff = 0
    for q, v, tau in _states(robot.nv, 200, 1):
        for h in (5e-4, 2.5e-4):
            a = lean.step(q, v, tau, h)
            b = general.step(q, v, tau, h)
            assert all(np.array_equal(x, y) for x, y in zip(a, b)), (q, v, tau, h)
        M_inv_diag = np.diag(pin.computeMinverse(robot.pin_model, robot.pin_model.createData(), q))
        stiff += 5e-4 * np.max(M_inv_diag * (lean.fc / 0.01 * (1 - np.tanh(v / 0.01) ** 2) + lean.fv)) > 0.1
    assert 0 < stiff < 200  # both branches compared


def test_the_general_step_stays_where_the_lean_one_does_not_apply():
    robot = load("exo_leg")
    assert not Plant(robot, robot.coulomb, robot.viscous, 0.01, {"passive": np.ones(2)})._lean
