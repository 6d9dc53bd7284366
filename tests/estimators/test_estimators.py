"""Estimators: the registry and contract, OLS / WLS / physically consistent LS on known problems."""

from __future__ import annotations

import numpy as np
import pytest

from pinid import TermSelection, identify
from pinid.errors import SolverError, SpecError
from pinid.identification.study import Study
from pinid.estimators import ESTIMATORS, OLS, WLS, Estimator, SDP, make_estimator
from pinid.problem.problem import IdentificationProblem
from pinid.model.physical import check_consistency

from conftest import load
from test_identification import relative_errors, true_base, truth_model, twin


@pytest.fixture(scope="module")
def leg_problem():
    model = truth_model("exo_leg")
    return IdentificationProblem.from_datasets(model, twin(model, seconds=10, rate=200, seed=1))


@pytest.fixture(scope="module")
def arm_problem():
    """UR5 moving a little around one posture, with torque noise: poorly excited."""
    model = truth_model("ur5")
    data = twin(
        model, seconds=15, rate=200, seed=0, noise=0.05, amplitude=0.05, around=[0.3, -1.0, 1.0, -0.5, 0.8, 0.2]
    )
    return IdentificationProblem.from_datasets(model, data)


def test_registry_and_contract():
    assert {"ols", "wls", "sdp"} <= set(ESTIMATORS)
    for name, cls in ESTIMATORS.items():
        assert issubclass(cls, Estimator) and cls.name == name
        est = make_estimator(name)
        assert not hasattr(est, "base_")  # __init__ only stores settings
        assert isinstance(est.get_params(), dict)
    assert make_estimator("WLS", iterations=3).get_params() == {"iterations": 3, "tol": 1e-10}
    with pytest.raises(SpecError, match="unknown method 'nope'.*ols"):
        make_estimator("nope")
    with pytest.raises(SpecError, match="method 'ols': bad settings"):
        make_estimator("ols", iterations=2)
    assert "regularization=0.001" in repr(SDP())


@pytest.mark.parametrize("cls", [OLS, WLS, SDP])
def test_fit_returns_self_with_fitted_values(cls, leg_problem):
    est = cls()
    assert est.fit(leg_problem) is est
    assert est.base_.shape == (leg_problem.nb,)
    np.testing.assert_allclose(est.predict(leg_problem.W), leg_problem.W @ est.base_)
    assert isinstance(est.info_, dict) and isinstance(est.status_, str)
    if cls is SDP:
        assert est.standard_.shape == (len(leg_problem.standard_names),)
        assert est.status_ == "optimal"
    else:
        assert est.standard_ is None


@pytest.mark.parametrize("cls", [OLS, WLS, SDP])
def test_noise_free_recovery(cls, leg_problem):
    model = leg_problem.model
    _, truth = true_base(model)
    est = cls().fit(leg_problem)
    assert relative_errors(model, est.base_, truth).max() <= 1e-6


def test_sdp_regularizer_does_not_bias_base_parameters_and_pulls_the_rest_to_nominal(leg_problem):
    model = leg_problem.model
    _, truth = true_base(model)
    plain = SDP(regularization=0.0).fit(leg_problem)
    strong = SDP(regularization=1.0).fit(leg_problem)  # 1000 × the default
    for est in (plain, strong):
        assert relative_errors(model, est.base_, truth).max() <= 1e-6
    # the nominal standard set is reproduced where the data cannot see (it is the truth here)
    nominal = leg_problem.nominal
    assert np.abs(strong.standard_ - nominal).max() < 1e-5 * np.abs(nominal).max()


def test_sdp_stays_consistent_where_ols_is_not(arm_problem):
    ols = OLS().fit(arm_problem)
    names = arm_problem.model.joint_names
    # OLS's base parameters are not realisable: no consistent standard set reproduces them
    from pinid.model.lmi import consistent_completion

    theta, why = consistent_completion(arm_problem, ols.base_)
    assert theta is None and why
    sdp = SDP().fit(arm_problem)
    assert sdp.status_ == "optimal"
    report = check_consistency(sdp.standard_, names, arm_problem.terms.names)
    assert report.consistent, report.problems
    assert min(b.relative for b in report.bodies) > 0  # strictly: the margin keeps J ≻ 0
    np.testing.assert_allclose(arm_problem.base.P @ sdp.standard_, sdp.base_)
    # its fit is close to OLS's (the data barely see the violated directions)
    r_ols = np.linalg.norm(arm_problem.tau - arm_problem.W @ ols.base_)
    r_sdp = np.linalg.norm(arm_problem.tau - arm_problem.W @ sdp.base_)
    assert r_ols <= r_sdp <= 1.05 * r_ols


def test_sdp_mass_matrix_positive_definite_at_10000_configurations(arm_problem):
    from pinid.identification.identified import IdentifiedModel

    sdp = SDP().fit(arm_problem)
    model = IdentifiedModel(arm_problem.model, arm_problem.terms, sdp.standard_)
    q, _, _ = arm_problem.model.random_states(10_000, np.random.default_rng(5))
    smallest = min(np.linalg.eigvalsh(model.mass_matrix(x))[0] for x in q)
    assert smallest > 0


def test_sdp_mass_bounds_and_infeasibility(leg_problem):
    est = SDP(mass_bounds={"knee": (5.0, 6.0)}).fit(leg_problem)
    assert 5.0 - 1e-7 <= est.standard_[10] <= 6.0 + 1e-7
    with pytest.raises(SolverError, match="infeasible.*mass bounds"):
        SDP(mass_bounds=(2.0, 1.0)).fit(leg_problem)


def test_sdp_solver_failure_is_an_error_not_a_result(leg_problem):
    with pytest.raises(SolverError, match="sdp: solver CLARABEL"):
        SDP(solver_options={"max_iter": 1}).fit(leg_problem)
    with pytest.raises(ValueError, match="weighting"):
        SDP(weighting="by-magic").fit(leg_problem)


def test_sdp_joint_weighting_and_nonnegative_joint_terms():
    model = truth_model("exo_leg", fc=0.0, fv=0.0)  # true friction zero: OLS estimates scatter around it
    problem = IdentificationProblem.from_datasets(
        model,
        twin(model, seconds=10, rate=200, seed=3, noise=[1.0, 0.1]),
        terms=TermSelection(coulomb=True, viscous=True, armature=True),
    )
    est = SDP(weighting="joint").fit(problem)
    joint = est.standard_[20:].reshape(2, 3)
    assert np.all(joint >= 0)
    assert est.weights_ is not None and est.weights_.max() / est.weights_.min() == pytest.approx(100, rel=0.1)


def test_wls_iterations_and_history(leg_problem):
    model = leg_problem.model
    noisy = IdentificationProblem.from_datasets(model, twin(model, seconds=10, rate=200, seed=4, noise=[1.0, 0.1]))
    est = WLS(iterations=5).fit(noisy)
    assert 1 <= len(est.history_) <= 5
    with pytest.raises(ValueError, match="iterations"):
        WLS(iterations=0).fit(noisy)


def test_iv_sim_rate_too_low_is_named_not_a_divergence():
    """Issue 33 (minor): iv.sim_rate=1e-6 said the simulation diverged ("raise bandwidth"); the rate is
    too low for the PD: RK4 needs ω·h ≤ 2.5, 2π·2 Hz / 2.5 = 5.03 Hz at the default bandwidth."""
    m = truth_model("exo_leg")
    problem = IdentificationProblem.from_datasets(m, [twin(m, seconds=2, rate=200)])
    with pytest.raises(
        SpecError, match=r"sim_rate=1e-06 Hz is too low for the PD bandwidth 2 Hz: expected sim_rate ≥ 5.03 Hz"
    ):
        make_estimator("iv", sim_rate=1e-6).fit(problem)


def test_estimator_settings_checked_when_made(tmp_path):
    """Case 6: a bad setting is a SpecError naming it when the estimator is made, before any data is read."""
    from pinid.estimators import make_estimator

    for method, setting in (
        ("wls", {"iterations": 0}),
        ("wls", {"iterations": -1}),
        ("sdp", {"regularization": -1}),
        ("sdp", {"regularization": float("nan")}),
        ("pso", {"population": "many"}),
    ):
        key = next(iter(setting))
        with pytest.raises(SpecError, match=f"setting {key}="):
            make_estimator(method, **setting)
        with pytest.raises(SpecError, match=f"setting {key}="):  # identify: before the (missing) recording
            identify(Study(load("exo_leg"), tmp_path / "missing.csv"), methods=method, options={method: setting})
