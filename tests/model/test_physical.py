"""Pseudo-inertia and consistency checks against point-mass bodies and Pinocchio's own conversions."""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

from pinid import TermSelection, standard_parameters
from pinid.model.physical import (
    PSEUDO_INERTIA_BASIS,
    check_consistency,
    com_inertia,
    from_pseudo_inertia,
    parameter_scale,
    pseudo_inertia,
)

from conftest import load


def point_masses(rng, n=5):
    """Standard parameters (about the origin) of n point masses, and their pseudo-inertia Σ m·[r;1][r;1]ᵀ."""
    m = rng.uniform(0.1, 2.0, n)
    r = rng.normal(scale=0.3, size=(n, 3))
    h = (m[:, None] * r).sum(0)
    I = sum(mk * (rk @ rk * np.eye(3) - np.outer(rk, rk)) for mk, rk in zip(m, r))
    pi = np.array([m.sum(), *h, I[0, 0], I[0, 1], I[1, 1], I[0, 2], I[1, 2], I[2, 2]])
    J = sum(mk * np.outer(np.r_[rk, 1.0], np.r_[rk, 1.0]) for mk, rk in zip(m, r))
    return pi, J


def test_pseudo_inertia_is_the_second_moment_of_the_mass():
    rng = np.random.default_rng(0)
    for _ in range(5):
        pi, J = point_masses(rng)
        np.testing.assert_allclose(pseudo_inertia(pi), J, atol=1e-12)
        np.testing.assert_allclose(from_pseudo_inertia(J), pi, atol=1e-12)
        assert check_consistency(pi, ["a"], []).consistent
    assert PSEUDO_INERTIA_BASIS.shape == (10, 4, 4)
    assert np.allclose(PSEUDO_INERTIA_BASIS, np.transpose(PSEUDO_INERTIA_BASIS, (0, 2, 1)))


def test_com_inertia_matches_pinocchio():
    rng = np.random.default_rng(1)
    for _ in range(5):
        pi, _ = point_masses(rng)
        m, c, I = com_inertia(pi)
        ref = pin.Inertia.FromDynamicParameters(pi)
        assert m == pytest.approx(ref.mass)
        np.testing.assert_allclose(c, ref.lever, atol=1e-12)
        np.testing.assert_allclose(I, ref.inertia, atol=1e-12)
    m, c, I = com_inertia(np.zeros(10))
    assert m == 0 and np.all(c == 0)


@pytest.mark.parametrize("name", ["exo_leg", "double_pendulum", "ur5", "panda"])
def test_urdf_robots_are_consistent(name):
    model = load(name)
    terms = TermSelection()
    report = check_consistency(standard_parameters(model, terms), model.joint_names, terms.names)
    assert report.consistent, report.problems
    assert report.to_dict()["consistent"] is True


def test_inconsistencies_are_found_and_named():
    rng = np.random.default_rng(2)
    pi, _ = point_masses(rng)
    bad_mass = pi.copy()
    bad_mass[0] = -1.0
    r = check_consistency(np.r_[pi, bad_mass, 0.3, 0.1, 0.2, 0.0], ["hip", "knee"], ["fc", "fv"])
    assert not r.consistent and r.problems[0].startswith("knee: pseudo-inertia") and "mass -1 kg" in r.problems[0]
    # inertia about the centre of mass positive definite, but a triangle inequality violated
    tri = np.array([1.0, 0, 0, 0, 3.0, 0, 1.0, 0, 0, 1.0])  # Ixx > Iyy + Izz
    assert np.all(np.linalg.eigvalsh(com_inertia(tri)[2]) > 0)
    assert not check_consistency(tri, ["a"], []).consistent
    # negative friction or armature is inconsistent; a negative offset is not
    terms = ["fc", "fv", "offset", "armature"]
    r = check_consistency(np.r_[pi, -0.1, 0.2, -5.0, 0.0], ["a"], terms)
    assert r.negative_terms == {"a.fc": -0.1}
    r = check_consistency(np.r_[pi, 0.1, 0.2, -5.0, -0.01], ["a"], terms)
    assert list(r.negative_terms) == ["a.armature"]
    # several: listed in column order (joint-major), the same in every process (no set order)
    r = check_consistency(np.r_[pi, pi, -0.1, -0.2, 0.0, 0.0, -0.3, -0.4], ["a", "b"], ["fc", "fv", "offset"])
    assert list(r.negative_terms) == ["a.fc", "a.fv", "b.fv"]
    with pytest.raises(ValueError, match="expected 14"):
        check_consistency(pi, ["a"], terms)


def test_parameter_scale_is_positive_and_in_units():
    model = load("exo_leg")
    theta = standard_parameters(model, TermSelection())
    s = parameter_scale(theta, model.nv, 2)
    assert s.shape == theta.shape and np.all(s > 0)
    m, L2 = s[0], s[4] / s[0]
    assert s[1] == pytest.approx(m * np.sqrt(L2)) and m == pytest.approx(theta[0])
