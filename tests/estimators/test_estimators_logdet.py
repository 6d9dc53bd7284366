"""The log-det divergence estimator (issue 34 item 3): the truth from noise-free data with a tiny weight, the
URDF with a huge one, physically consistent always, the weight chosen by blocked cross-validation."""

from __future__ import annotations

import numpy as np
import pytest

from pinid.errors import SpecError
from pinid.estimators import ESTIMATORS, make_estimator, quick_methods
from pinid.estimators.logdet import GRID, LogDet
from pinid.model.physical import check_consistency
from pinid.problem.problem import IdentificationProblem

from test_identification import relative_errors, true_base, truth_model, twin


@pytest.fixture(scope="module")
def heavier():
    """Noise-free data of an exo leg 30 % heavier than its URDF (every inertial parameter × 1.3), fitted with
    the URDF's values as the prior; returns (problem, true base parameters, true standard parameters)."""
    urdf = truth_model("exo_leg")
    truth = urdf.with_inertial_parameters(1.3 * urdf.inertial_parameters(), coulomb=urdf.coulomb, viscous=urdf.viscous)
    problem = IdentificationProblem.from_datasets(urdf, twin(truth, seconds=6, rate=100, seed=3))
    return problem, true_base(truth)[1], truth


def _consistent(problem, theta) -> bool:
    return check_consistency(
        theta, problem.model.joint_names, problem.terms.names, problem.model.motor_names
    ).consistent


def test_registered_and_left_out_of_the_quick_defaults():
    assert ESTIMATORS["logdet"] is LogDet and "logdet" not in quick_methods() and not LogDet.simulates


def test_tiny_weight_returns_the_truth_not_the_urdf(heavier):
    problem, truth, _ = heavier
    est = make_estimator("logdet", weight=1e-8).fit(problem)
    err = relative_errors(problem.model, est.base_, truth)
    assert err.max() <= 1e-4, dict(zip(problem.names, err))
    assert _consistent(problem, est.standard_) and est.status_ in ("optimal", "optimal_inaccurate")
    assert est.info_["weight"] == 1e-8 and len(est.info_["divergence"]) == problem.nv


def test_huge_weight_returns_the_urdf(heavier):
    problem, _, _ = heavier
    bodies = slice(0, 10 * problem.nv)
    nominal = problem.nominal[bodies]
    far = []
    for w in (1e-8, 1e2, 1e6):
        theta = make_estimator("logdet", weight=w).fit(problem).standard_
        assert _consistent(problem, theta)
        far.append(np.abs(theta[bodies] - nominal).max() / np.abs(nominal).max())
    assert far[0] > 0.05 and far[2] < 1e-3 and far[0] > far[1] > far[2], far


def test_auto_weight_by_blocked_cross_validation(heavier):
    problem, truth, _ = heavier
    est = make_estimator("logdet").fit(problem)
    curve = est.info_["curve"]
    assert curve["weights"] == list(GRID) and len(curve["heldout_relative_rms"]) == len(GRID)
    best = int(np.nanargmin([np.inf if s is None else s for s in curve["heldout_relative_rms"]]))
    assert est.info_["weight"] == curve["chosen"] == GRID[best]
    # noise-free: nothing to gain from the prior, the smallest weight wins and the truth comes back
    assert est.info_["weight"] == GRID[0]
    assert relative_errors(problem.model, est.base_, truth).max() <= 1e-4
    assert _consistent(problem, est.standard_)


@pytest.mark.parametrize("bad", [-1.0, "often", True, float("nan"), [1.0]])
def test_bad_weight_is_a_spec_error(bad, heavier):
    with pytest.raises(SpecError, match="method 'logdet': setting weight="):
        make_estimator("logdet", weight=bad)
    with pytest.raises(SpecError, match="weight"):
        LogDet(weight=bad).fit(heavier[0])
