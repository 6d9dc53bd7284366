"""The essential-parameters estimator (issue 34 item 3): poorly determined base parameters fixed to the URDF."""

from __future__ import annotations

import numpy as np
import pytest

from pinid.errors import SpecError
from pinid.estimators import ESTIMATORS, make_estimator
from pinid.estimators.essential import Essential
from pinid.identification.result import make_result
from pinid.model.terms import TermSelection
from pinid.problem.problem import IdentificationProblem

from test_identification import relative_errors, true_base, truth_model, twin

TERMS = TermSelection(coulomb=True, viscous=True, armature=True)


def test_registered_with_its_settings():
    assert ESTIMATORS["essential"] is Essential
    assert make_estimator("essential", threshold=5).get_params() == {"threshold": 5, "max_growth": 0.01}
    with pytest.raises(SpecError, match="threshold"):
        make_estimator("essential", threshold=0)
    with pytest.raises(SpecError, match="max_growth"):
        make_estimator("essential", max_growth=-1.0)


def test_noise_free_well_excited_twin_drops_nothing_and_recovers_the_truth():
    model = truth_model("exo_leg")
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=10, rate=200, seed=1), terms=TERMS)
    est = Essential().fit(problem)
    assert est.info_["fixed"] == []
    assert list(est.info_["identified"]) == problem.names
    assert relative_errors(model, est.base_, true_base(model, TERMS)[1], TERMS).max() <= 1e-6


def test_slow_noisy_twin_fixes_the_armature_to_the_urdf_and_recovers_the_rest():
    """A slow motion (0.05 Hz) barely accelerates: the armature's column is small and its estimate noise."""
    model = truth_model("exo_leg")
    data = twin(model, seconds=10, rate=200, seed=1, noise=[0.5, 0.05], frequency=0.05)
    problem = IdentificationProblem.from_datasets(model, data, terms=TERMS)
    truth = true_base(model, TERMS)[1]
    est = Essential().fit(problem)
    names = problem.names
    fixed = [names.index(n) for n in est.info_["fixed"]]
    assert "knee.armature" in est.info_["fixed"]
    assert np.array_equal(est.base_[fixed], problem.nominal_base[fixed])  # fixed to the URDF's values
    assert max(est.info_["identified"].values()) <= 10.0  # every kept one below the threshold [%]
    assert est.info_["residual_growth"] <= 0.01
    kept = [i for i in range(problem.nb) if i not in fixed]
    err = relative_errors(model, est.base_, truth, TERMS)
    ols = relative_errors(model, make_estimator("ols").fit(problem).base_, truth, TERMS)
    assert err[kept].max() <= 0.05, dict(zip(names, err))
    assert err.max() < ols.max()
    assert est.history_[0] <= est.history_[-1] <= 1.01 * est.history_[0]  # residual norm per pass
    result = make_result(problem, est, 0.0)
    assert result.info["fixed"] == est.info_["fixed"] and result.method == "essential"


def test_blocked_problem_gives_what_the_built_regressor_gives():
    """hac_std reads the kept columns block by block while W is not built (issue 35), or from W once built."""
    model = truth_model("exo_leg")
    data = twin(model, seconds=10, rate=200, seed=1, noise=[0.5, 0.05], frequency=0.05)
    problem = IdentificationProblem.from_datasets(model, data, terms=TERMS)
    assert problem.blocked
    blocked = Essential().fit(problem)
    assert problem.W.shape == (problem.rows, problem.nb)  # built whole from here on
    assert not problem.blocked
    whole = Essential().fit(problem)
    assert blocked.info_["fixed"] == whole.info_["fixed"]
    np.testing.assert_allclose(blocked.base_, whole.base_, rtol=1e-9)
    np.testing.assert_allclose(
        list(blocked.info_["identified"].values()), list(whole.info_["identified"].values()), rtol=1e-6
    )
