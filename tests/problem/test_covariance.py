"""The Newey–West covariance of the base parameters (pinid/problem/covariance.py) against Monte-Carlo truth."""

from __future__ import annotations

import numpy as np
import pytest

from pinid.estimators import make_estimator
from pinid.identification.result import make_result
from pinid.problem.covariance import andrews_bandwidth, bartlett_long_run, hac_covariance
from pinid.problem.problem import IdentificationProblem
from pinid.problem.statistics import base_statistics

from test_identification import truth_model, twin


def _ar1(rng, n, rho, reps):
    """``reps`` AR(1) series of length ``n`` with unit innovations, started stationary."""
    e = rng.normal(size=(reps, n))
    x = np.empty_like(e)
    x[:, 0] = e[:, 0] / np.sqrt(1 - rho**2)
    for t in range(1, n):
        x[:, t] = rho * x[:, t - 1] + e[:, t]
    return x


def test_bartlett_window_sums_equal_the_explicit_lag_sum():
    g = np.random.default_rng(0).normal(size=(300, 3))
    lag = 7
    S = g.T @ g
    for k in range(1, lag + 1):
        G = g[k:].T @ g[:-k]
        S += (1 - k / (lag + 1)) * (G + G.T)
    np.testing.assert_allclose(bartlett_long_run(g, lag), S, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(bartlett_long_run(g, 0), g.T @ g)


def test_hac_sigma_matches_the_monte_carlo_spread_where_white_sigma_is_far_too_small():
    """Regression on a slowly varying regressor with AR(1) noise (ρ = 0.95): the spread of the OLS slope
    over 400 draws is the truth; the HAC σ is within 20 % of it, the white σ several times too small."""
    rng = np.random.default_rng(1)
    n, reps, rho = 1500, 400, 0.95
    t = np.arange(n)
    X = np.column_stack([np.ones(n), np.sin(2 * np.pi * t / 300)])
    E = _ar1(rng, n, rho, reps)
    Binv = np.linalg.inv(X.T @ X)
    est = E @ X @ Binv  # (reps, 2) estimation errors
    spread = est.std(axis=0)
    hac, white = [], []
    for k in range(reps):
        r = E[k] - X @ est[k]
        cov, _ = hac_covariance(Binv, X * r[:, None], [(0, n)], n / (n - 2))
        hac.append(np.sqrt(np.diag(cov)))
        white.append(np.sqrt(r @ r / (n - 2) * np.diag(Binv)))
    hac, white = np.mean(hac, axis=0), np.mean(white, axis=0)
    np.testing.assert_allclose(hac, spread, rtol=0.2)
    assert np.all(spread / white > 3)


def test_andrews_bandwidth_grows_with_the_correlation():
    rng = np.random.default_rng(2)
    white = andrews_bandwidth(rng.normal(size=(2000, 2)))
    slow = andrews_bandwidth(_ar1(rng, 2000, 0.9, 2).T)
    assert white <= 3 < 10 < slow


@pytest.fixture(scope="module")
def leg():
    model = truth_model("exo_leg")
    return model, IdentificationProblem.from_datasets(model, twin(model, seconds=5, rate=200, seed=1, noise=0.05))


def test_white_noise_recording_gives_hac_sigma_close_to_white(leg):
    """Independent noise: the sandwich agrees with σ²(WᵀW)⁻¹ (the Fourier regressor is smooth, so the
    residual scores are white and the bandwidth small)."""
    _, problem = leg
    x = make_estimator("ols").fit(problem).base_
    hac = base_statistics(problem, x)[0]
    white = base_statistics(problem, x, kind="white")[0]
    np.testing.assert_allclose(hac, white, rtol=0.35)


def test_metaheuristics_give_no_sigma(leg):
    _, problem = leg
    est = make_estimator("pso", seed=0, iterations=5, population=8).fit(problem)
    r = make_result(problem, est, 0.0, complete=False)
    assert np.all(np.isnan(r.std))
    assert all(v is None for v in r.to_dict()["std"].values())
    assert all(v is None for v in r.to_dict()["std_percent"].values())
    ols = make_result(problem, make_estimator("ols").fit(problem), 0.0, complete=False)
    assert np.all(np.isfinite(ols.std))


def test_sdp_parameter_on_a_bound_gives_no_sigma():
    """True viscous friction −0.5 N·m·s/rad: sdp holds fv ≥ 0 at the bound, so its σ is not printed."""
    model = truth_model("exo_leg", fv=-0.5)
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=5, rate=200, seed=2, noise=0.05))
    r = make_result(problem, make_estimator("sdp").fit(problem), 0.0, complete=False)
    fv = [i for i, n in enumerate(r.base_names) if n.endswith(".fv")]
    assert np.all(np.isnan(r.std[fv]))
    others = [i for i in range(len(r.base)) if i not in fv]
    assert np.all(np.isfinite(r.std[others]))


def test_kernel_bias_lag_follows_slow_correlation_where_andrews_stops():
    """Issue 47: the kernel-bias lag (5 % bias: L + 1 = ŝ₁/(0.05·ŝ₀), for AR(1) ŝ₁/ŝ₀ = 2ρ/(1 − ρ²)) follows
    slow correlation; Andrews' AR(1) rule, its ρ clipped at 0.97, stops near 320 at 20 000 samples."""
    from pinid.problem.covariance import bias_bandwidth, choose_lag

    rng = np.random.default_rng(3)
    white = rng.normal(size=(20000, 3))
    assert choose_lag(white) <= 3
    slow = _ar1(rng, 20000, 0.995, 3).T
    theory = 2 * 0.995 / (1 - 0.995**2) / 0.05
    assert andrews_bandwidth(slow) < 400
    assert 0.7 * theory < bias_bandwidth(slow) < 2 * theory
    assert choose_lag(slow) == bias_bandwidth(slow)
    assert choose_lag(slow[:300]) <= 299  # never past the recording


def test_binned_autocorrelation_gives_the_same_lag(monkeypatch):
    """Long recordings: the autocorrelation on bins of summed scores (the streamed path's) gives about the
    whole-sample lag when the correlation is longer than a bin."""
    from pinid.problem import covariance as cv

    g = _ar1(np.random.default_rng(4), 20000, 0.995, 2).T
    whole = cv.bias_bandwidth(g)
    monkeypatch.setattr(cv, "ACF_BINS", 1000)
    binned, m = cv.binned_scores(g)
    assert m == 20 and len(binned) == 1000
    assert cv.bias_bandwidth(binned, m) == pytest.approx(whole, rel=0.1)


def test_fixed_b_factor():
    from pinid.problem.covariance import fixed_b_factor

    assert fixed_b_factor(0, 100) == 1.0
    assert fixed_b_factor(49, 100) == pytest.approx(1 - 0.5 + 0.25 / 3)
    assert fixed_b_factor(10**6, 100) == pytest.approx(1 / 3)
