"""The real-data estimators (issue 28): iv (IDIM-IV), didim, tls, irls against the truth.

Noise-free twin: the truth to 1e-6 where the method is consistent there (iv, tls, irls and their
physically consistent variants); DIDIM only up to its simulation between samples (measured and bounded).
Outliers: IRLS far closer to the truth than OLS.  Noise on q: on one recording DIDIM is less biased than
OLS and IV is bounded; the Monte-Carlo study (docs/identification.md, "Real-data estimators") says how
far that generalises (not far).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from pinid.data.dataset import Dataset
from pinid.errors import SpecError
from pinid.estimators import make_estimator
from pinid.problem.problem import IdentificationProblem
from pinid.problem.recordings import prepare_dataset
from pinid.model.physical import check_consistency

from test_identification import relative_errors, true_base, truth_model, twin


@pytest.fixture(scope="module")
def clean():
    model = truth_model("exo_leg")
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=6, rate=100, seed=3))
    return problem, true_base(model)[1]


@pytest.mark.parametrize(
    "name, settings",
    [
        ("iv", {}),
        ("iv", {"physical": True}),
        ("tls", {}),
        ("tls", {"scaling": "none"}),
        ("irls", {}),
        ("irls", {"loss": "tukey"}),
        ("irls", {"physical": True}),
    ],
)
def test_noise_free_twin_recovered_to_1e_6(name, settings, clean):
    problem, truth = clean
    est = make_estimator(name, **settings).fit(problem)
    err = relative_errors(problem.model, est.base_, truth)
    assert err.max() <= 1e-6, dict(zip(problem.names, err))
    if settings.get("physical"):
        report = check_consistency(
            est.standard_, problem.model.joint_names, problem.terms.names, problem.model.motor_names
        )
        assert report.consistent, report.problems
        np.testing.assert_allclose(problem.base.P @ est.standard_, est.base_, rtol=1e-9, atol=1e-12)


def test_didim_noise_free_limited_by_its_simulation_and_its_cost_never_rises():
    """Without Coulomb friction (no torque jump inside a sample interval) DIDIM lands within 1e-3 of the truth
    (measured 1.1e-4 at 100 Hz); its output error never rises from one step to the next."""
    model = truth_model("exo_leg", fc=0.0)
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=6, rate=100, seed=3))
    est = make_estimator("didim").fit(problem)
    err = relative_errors(problem.model, est.base_, true_base(model)[1])
    assert err.max() <= 1e-3, dict(zip(problem.names, err))
    h = np.array(est.history_)
    assert len(h) >= 2 and np.all(np.diff(h) <= 1e-12 * h[0])
    assert est.info_["start"] == "ols"


def test_tls_compressed_equals_the_svd_of_the_tall_matrix(clean):
    """TLS through the (nb+1)² compressed form equals the SVD of the tall, column-scaled [W | τ] (noisy data)."""
    problem, _ = clean
    rng = np.random.default_rng(0)
    noisy = IdentificationProblem.from_datasets(
        problem.model,
        Dataset(
            problem.regressor_rows.datasets[0].t,
            problem.regressor_rows.datasets[0].q,
            problem.model.joint_names,
            dq=problem.regressor_rows.datasets[0].dq,
            ddq=problem.regressor_rows.datasets[0].ddq,
            tau=problem.regressor_rows.datasets[0].tau + rng.normal(0, 0.5, (problem.samples, problem.nv)),
        ),
    )
    W, tau = noisy.W, noisy.tau
    s = np.linalg.norm(W, axis=0)
    A = np.column_stack([W / s, tau / np.linalg.norm(tau)])
    v = np.linalg.svd(A, full_matrices=False)[2][-1]
    direct = -v[:-1] / v[-1] * np.linalg.norm(tau) / s
    est = make_estimator("tls").fit(noisy)
    np.testing.assert_allclose(est.base_, direct, rtol=1e-7)
    ols = make_estimator("ols").fit(noisy).base_
    assert np.linalg.norm(est.base_ - ols) > 1e-6 * np.linalg.norm(ols)  # not least squares in disguise


@pytest.mark.parametrize("loss", ["huber", "tukey"])
def test_irls_robust_to_torque_outliers(loss):
    """3 % of the torque samples hit by spikes of 20× the torque's RMS: OLS is off by more than 100 %, IRLS
    within 1 % of the truth (measured 0.15–0.28 % on seeds 0–2)."""
    model = truth_model("exo_leg")
    ds = twin(model, seconds=6, rate=100, seed=0, noise=0.01)
    rng = np.random.default_rng(0)
    tau = ds.tau.copy()
    hit = rng.choice(tau.size, size=int(0.03 * tau.size), replace=False)
    tau.flat[hit] += rng.choice([-1, 1], size=hit.size) * 20 * np.sqrt(np.mean(tau**2))
    problem = IdentificationProblem.from_datasets(model, Dataset(ds.t, ds.q, ds.joints, dq=ds.dq, ddq=ds.ddq, tau=tau))
    truth = true_base(model)[1]
    ols = relative_errors(model, make_estimator("ols").fit(problem).base_, truth).max()
    est = make_estimator("irls", loss=loss).fit(problem)
    robust = relative_errors(model, est.base_, truth).max()
    assert ols > 1.0 and robust < 0.01, (ols, robust)
    assert est.info_["downweighted"] >= 0.02  # the spikes (3 % of the rows) are the rows it set aside


@pytest.mark.slow
def test_noise_on_q_didim_less_biased_than_ols():
    """Open-loop motion, exact torques, Gaussian noise of 1 mrad on q, default preprocessing (10 Hz): errors in
    the regressor bias OLS (largest error 33 % here).  On this recording DIDIM's largest error is below half
    OLS's (measured 6 %) and IV's is not worse than twice OLS's (measured 21 %).  Over the 20 seeds of the
    Monte-Carlo study DIDIM lowers the largest bias but not the mean error, and IV does not help
    (docs/identification.md, "Real-data estimators"): this checks one recording, not a general claim."""
    model = truth_model("exo_leg")
    ds = twin(model, seconds=8, rate=100, seed=1)
    raw = Dataset(ds.t, ds.q + np.random.default_rng(51).normal(0, 1e-3, ds.q.shape), ds.joints, tau=ds.tau)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem = IdentificationProblem.from_datasets(model, prepare_dataset(raw, {}))
    truth = true_base(model)[1]
    err = {m: relative_errors(model, make_estimator(m).fit(problem).base_, truth).max() for m in ("ols", "iv", "didim")}
    assert err["didim"] < 0.5 * err["ols"], err
    assert err["iv"] < 2 * err["ols"], err


@pytest.mark.parametrize("name", ["iv", "didim"])
def test_simulating_estimators_need_the_recordings(name, clean):
    problem, _ = clean
    bare = IdentificationProblem(
        problem.model, problem.terms, problem.base, problem.W, problem.tau, problem.joint, problem.sample,
        problem.weights, problem.nominal,
    )  # fmt: skip
    with pytest.raises(SpecError, match="problem made from recordings"):
        make_estimator(name).fit(bare)
