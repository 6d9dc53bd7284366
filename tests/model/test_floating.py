"""Floating base (issue 27): the free-flyer regressor, contact wrenches, base parameters."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from pinid import FloatingRobotModel, ModelError, RobotModel
from pinid.model.base import base_parameters
from pinid.model.floating import Wrench, contact_forces, floating_rnea, random_floating_states
from pinid.model.regressor import parameter_names, regressor, standard_parameters
from pinid.model.terms import TermSelection

NONE = TermSelection.from_names("none")


@pytest.fixture(scope="module")
def exo() -> FloatingRobotModel:
    return RobotModel.from_urdf("exo_lower_body", base="floating")


@pytest.mark.parametrize("name", ["exo_lower_body", "talos_legs", "solo12", "anymal"])
def test_regressor_times_parameters_is_rnea_on_the_free_flyer(name):
    """6 + n rows per sample; W·θ equals Pinocchio's RNEA (base wrench and joint torques) to rounding."""
    model = RobotModel.from_urdf(name, base="floating")
    states = random_floating_states(model, 12, np.random.default_rng(3))
    W = regressor(model, *model.full_state(*states), NONE)
    assert W.shape == (12 * (6 + model.nv), 10 * (model.nv + 1))
    tau = (W @ standard_parameters(model, NONE)).reshape(12, 6 + model.nv)
    ref = floating_rnea(model, *states)
    assert np.abs(tau - ref).max() <= 1e-9 * max(1.0, np.abs(ref).max())
    assert np.abs(ref[:, :6]).max() > 1.0  # the base rows carry signal


def test_joint_rows_add_the_joint_terms(exo):
    terms = TermSelection.from_names("fc,fv")
    states = random_floating_states(exo, 8, np.random.default_rng(4))
    theta = standard_parameters(exo, terms)
    names = parameter_names(exo, terms)
    assert names[:2] == ["base.m", "base.mx"] and "l_knee.fc" in names and "base.fc" in names
    tau = (regressor(exo, *exo.full_state(*states), terms) @ theta).reshape(8, -1)
    dq = states[4]
    friction = exo.coulomb * np.sign(dq) + exo.viscous * dq
    ref = floating_rnea(exo, *states)
    np.testing.assert_allclose(tau[:, 6:], ref[:, 6:] + friction, atol=1e-9)
    np.testing.assert_allclose(tau[:, :6], ref[:, :6], atol=1e-9)  # no friction on the free flyer
    bp = base_parameters(exo, terms)
    assert {"base.fc", "base.fv"} <= set(bp.unidentifiable)


def test_contact_forces_match_rnea_with_external_forces(exo):
    """Σ Jᵀf (link-frame and world-frame wrenches) is what Pinocchio's RNEA with fext subtracts."""
    rng = np.random.default_rng(5)
    states = random_floating_states(exo, 5, rng)
    local = rng.normal(size=(5, 6)) * 50
    world = rng.normal(size=(5, 6)) * 50
    gen = contact_forces(exo, states[0], states[3], [Wrench("l_sole", local), Wrench("r_foot", world, "world")])
    m, d = exo.ff_model, exo.ff_model.createData()
    Q, V, A = exo.full_state(*states)
    for k in range(5):
        pin.forwardKinematics(m, d, Q[k])
        pin.updateFramePlacements(m, d)
        fext = [pin.Force.Zero() for _ in range(m.njoints)]
        sole = m.frames[m.getFrameId("l_sole")]
        fext[sole.parentJoint] += sole.placement.act(pin.Force(local[k]))
        foot = m.frames[m.getFrameId("r_foot")]
        fext[foot.parentJoint] += d.oMi[foot.parentJoint].actInv(pin.Force(world[k]))
        ref = pin.rnea(m, d, Q[k], V[k], A[k], fext)
        np.testing.assert_allclose(pin.rnea(m, d, Q[k], V[k], A[k]) - gen[k], ref, atol=1e-8)


def test_base_rows_alone_identify_the_total_mass(exo):
    """The 6 base rows (no joint torque) determine the total mass: base.mR = Σ masses; the joint rows alone do not."""
    base_rows = base_parameters(exo, NONE, rows="base")
    joint_rows = base_parameters(exo, NONE, rows="joints")
    both = base_parameters(exo, NONE)
    theta = standard_parameters(exo, NONE)
    total = sum(theta[10 * i] for i in range(exo.nv + 1))
    assert base_rows.names[0] == "base.mR"
    assert base_rows.from_standard(theta)[0] == pytest.approx(total)
    assert "base.m" in joint_rows.unidentifiable and "base.m" not in both.unidentifiable
    assert joint_rows.count < both.count and base_rows.count <= both.count


def test_fixed_base_stays_the_default_and_bad_base_is_refused():
    assert RobotModel.from_urdf("exo_lower_body").base == "fixed"
    assert type(RobotModel.from_urdf("exo_leg")) is RobotModel
    with pytest.raises(ModelError, match="base='flying'"):
        RobotModel.from_urdf("exo_leg", base="flying")


def test_non_unit_quaternion_is_refused(exo):
    states = list(random_floating_states(exo, 3, np.random.default_rng(0)))
    states[0][1, 3:] *= 1.1
    with pytest.raises(ValueError, match="sample 1 has norm"):
        floating_rnea(exo, *states)


def test_cli_info_floating_shows_the_base_parameters(tmp_path):
    from conftest import run_cli

    proc = run_cli(
        "info", "--urdf", "exo_lower_body", "--base", "floating", "--terms", "none", "--json", "i.json", cwd=tmp_path
    )
    assert proc.returncode == 0, proc.stderr
    assert "base: floating (free flyer under link 'pelvis'" in proc.stdout
    assert "base.mR" in proc.stdout and "from the 6 base rows alone" in proc.stdout
    import json

    d = json.loads((tmp_path / "i.json").read_text())
    assert d["base"] == "floating" and d["base_rows"]["count"] == len(d["base_parameters"])  # Ayusawa et al. 2014
    assert d["base_parameters"][0]["nominal"] == pytest.approx(21.8)


def test_self_collision_between_the_legs(exo):
    """16 pairs (4 bodies per leg); hips adducted make the thighs overlap; a motion that swings them together
    is shrunk toward its clear offsets until the legs stay 2 cm apart."""
    from pinid import SpecError
    from pinid.excitation.collision import check_self_collision, leg_pairs, shrink_to_clear
    from pinid.excitation.trajectory import FourierTrajectory

    _, pairs = leg_pairs(exo)
    assert len(pairs) == 16
    zeros = np.zeros((8, 1))
    adducted = np.zeros(8)
    adducted[[0, 4]] = -0.35
    crossed = FourierTrajectory(exo.joint_names, 1.0, adducted, zeros, zeros)
    assert check_self_collision(exo, crossed).distance < 0
    with pytest.raises(SpecError, match="at the offsets q0"):
        shrink_to_clear(exo, crossed)
    a = zeros.copy()
    a[[0, 4], 0] = -0.34  # both hips adduct together once per period
    swing = FourierTrajectory(exo.joint_names, 1.0, np.zeros(8), a, zeros)
    shrunk, factor, check = shrink_to_clear(exo, swing)
    assert 0 < factor < 1 and check.ok and check.distance < 0.021
    assert not check_self_collision(exo, swing).ok


@pytest.mark.parametrize("name", ["exo_lower_body", "talos_legs"])
def test_floating_urdf_round_trip(name, tmp_path):
    """The exported URDF loads back (floating) with the given parameters, the base link's included."""
    from pinid.model.export import floating_urdf

    model = RobotModel.from_urdf(name, base="floating")
    terms = TermSelection.from_names("fc,fv")
    theta = standard_parameters(model, terms)
    theta[0] *= 1.1  # a heavier base (first moments unchanged: its centre of mass moves in)
    theta[10 + 10 * 2] *= 1.2  # and a heavier third body
    path = tmp_path / "id.urdf"
    floating_urdf(model, theta, terms, path)
    back = RobotModel.from_urdf(path, base="floating", locked=model.locked or None)
    np.testing.assert_allclose(standard_parameters(back, terms), theta, atol=1e-12)
    theta[0] = -1.0
    with pytest.raises(ModelError, match="inconsistent"):
        floating_urdf(model, theta, terms)
