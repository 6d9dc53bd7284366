"""The tall base regressor in blocks (issue 17): a problem from recordings never builds ``W`` whole for
OLS and the LMI fit, and gives what the whole matrix gives."""

from __future__ import annotations

import numpy as np
import pytest

import pinid.problem.problem as problem_module
from pinid.identification.study import Study
from pinid.estimators import make_estimator
from pinid.problem.problem import IdentificationProblem, RegressorRows, check_dataset, stack_rows
from pinid.problem.rows import rest_threshold
from pinid.identification.result import make_result
from pinid.identification.run import identify
from pinid.linalg import augmented_r, cholesky_r
from pinid.model.terms import TermSelection

from test_identification import truth_model, twin

CHUNK = 250  # samples per block in these tests: several blocks per recording


def relative(a, b) -> float:
    """Largest difference of ``a`` and ``b`` relative to the largest magnitude of ``b``."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-300))


def recordings(model, **motion):
    """Two noisy twin recordings (20 s and 8 s at 200 Hz): rows at rest are dropped in both."""
    return [twin(model, seed=1, noise=0.05, **motion), twin(model, seconds=8, seed=2, noise=0.05, **motion)]


def same_residual(rho: float, rho0: float, c0: np.ndarray) -> bool:
    """``rho`` is ``√(‖y‖² − ‖c‖²)`` in the Cholesky path: equal to round-off relative to ‖y‖²."""
    return abs(rho**2 - rho0**2) < 1e-12 * (c0 @ c0 + rho0**2)


def whole(problem: IdentificationProblem) -> IdentificationProblem:
    """The same problem with its regressor given whole (the path of a problem built from an array)."""
    q = IdentificationProblem(
        problem.model,
        problem.terms,
        problem.base,
        problem.regressor_rows.build(),
        problem.tau,
        problem.joint,
        problem.sample,
        problem.weights,
        problem.nominal,
    )
    q.recording_sizes = [ds.n for ds in problem.regressor_rows.datasets]  # where the HAC windows stop
    return q


@pytest.fixture(autouse=True)
def small_blocks(monkeypatch):
    monkeypatch.setattr(problem_module, "_CHUNK", CHUNK)


@pytest.mark.parametrize("name", ["exo_leg", "ur5"])
def test_blocked_rows_and_compressed_form_equal_the_whole_regressor(name):
    model = truth_model(name)
    data = recordings(model)
    p = IdentificationProblem.from_datasets(model, data)
    assert p.blocked and p.dropped.sum() > 0  # rows at rest were left out of the blocks
    R, c, rho, scale = p.compressed()
    # the rows rebuilt block by block are those stack_rows builds whole, in the order of tau
    checked = [check_dataset(ds, model) for ds in data]
    thresholds = [rest_threshold(ds, model, TermSelection()) for ds in checked]
    W, tau, joint, sample = stack_rows(model, TermSelection(), p.base, checked, thresholds)
    assert p.blocked  # nothing above built W
    np.testing.assert_array_equal(p.W, W)
    np.testing.assert_array_equal(p.tau, tau)
    np.testing.assert_array_equal(p.sample, sample)
    R0, c0, rho0, scale0 = augmented_r(W, tau, p.weights)
    assert relative(R, R0) < 1e-10 and relative(c, c0) < 1e-10 and relative(scale, scale0) < 1e-10
    assert same_residual(rho, rho0, c0)
    # other row weights, block by block too
    w = 1.0 + p.joint
    q = IdentificationProblem.from_datasets(model, data)
    Rw, cw, rhow, scalew = q.compressed(w)
    assert q.blocked
    R0, c0, rho0, scale0 = augmented_r(W, tau, w)
    assert relative(Rw, R0) < 1e-10 and relative(cw, c0) < 1e-10 and same_residual(rhow, rho0, c0)
    np.testing.assert_allclose(q.predict(np.arange(q.nb)), W @ np.arange(q.nb), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("name", ["exo_leg", "ur5"])
def test_ols_and_sdp_results_equal_the_whole_regressor_path(name):
    model = truth_model(name)
    p = IdentificationProblem.from_datasets(model, recordings(model))
    q = whole(p)
    assert not q.blocked
    for method in ("ols", "sdp"):
        blocked = make_result(p, make_estimator(method).fit(p), 0.0)
        full = make_result(q, make_estimator(method).fit(q), 0.0)
        assert relative(blocked.base, full.base) < 1e-9, method
        assert relative(blocked.std, full.std) < 1e-9, method
        assert abs(blocked.condition_number / full.condition_number - 1) < 1e-9, method
        scaled = blocked.info["condition_number_scaled"], full.info["condition_number_scaled"]
        assert abs(scaled[0] / scaled[1] - 1) < 1e-9, method
        for joint, m in full.train.per_joint.items():
            for k, v in m.items():
                assert abs(blocked.train.per_joint[joint][k] - v) <= 1e-9 * abs(v), (method, joint, k)
    assert p.blocked  # W was never built whole
    assert p.__dict__.get("_W") is None


def test_identify_with_ols_and_sdp_never_builds_the_whole_regressor(monkeypatch):
    model = truth_model("exo_leg")

    def refuse(self):
        raise AssertionError("the whole regressor was built")

    monkeypatch.setattr(RegressorRows, "build", refuse)
    # the identification's own problem; the default terms' offset test holds at most term_choice.CV_SAMPLES
    # samples' rows whole (bounded whatever the recordings' length: tests/test_memory_data_path.py)
    res = identify(Study(model, recordings(model), terms="fc,fv"), methods=["ols", "sdp"])
    assert set(res.results) == {"ols", "sdp"}
    # wls reads problem.W: built on demand, so every estimator still works
    monkeypatch.undo()
    assert identify(Study(model, recordings(model)), methods=["ols", "wls"])["wls"].train.all["rms"] > 0


def test_ill_conditioned_gram_falls_back_to_qr_of_the_whole_regressor():
    """A small motion around one posture with a torque offset: the gravity columns are nearly collinear
    with the offset column, the Gram matrix too ill-conditioned for Cholesky, the regressor still full rank."""
    model = truth_model("exo_leg")
    data = [twin(model, seed=3, noise=0.01, amplitude=3e-3)]
    terms = TermSelection(offset=True)
    p = IdentificationProblem.from_datasets(model, data, terms=terms)
    assert cholesky_r(*p.gram()) is None
    assert not p.blocked  # the rank check needed the QR factorisation of the whole W
    R, c, rho, scale = p.compressed()
    R0, c0, rho0, scale0 = augmented_r(p.W, p.tau, p.weights)
    assert relative(R, R0) < 1e-10 and relative(c, c0) < 1e-10 and abs(rho - rho0) < 1e-10 * rho0
    q = whole(p)
    a = make_result(p, make_estimator("ols").fit(p), 0.0)
    b = make_result(q, make_estimator("ols").fit(q), 0.0)
    assert relative(a.base, b.base) < 1e-9
    assert relative(a.std, b.std) < 1e-3  # HAC σ: the ill-conditioned fit's residual scores differ at round-off × cond


@pytest.mark.parametrize("limit", [problem_module.KEEP_BLOCKS_BYTES, 0])
def test_small_problems_keep_their_blocks_after_the_first_pass(monkeypatch, limit):
    """Issue 35: the Gram sums, the HAC σ and the predictions of every method read the blocks of the first
    pass (the same arrays, read-only) instead of rebuilding them; above KEEP_BLOCKS_BYTES every pass rebuilds."""
    monkeypatch.setattr(problem_module, "KEEP_BLOCKS_BYTES", limit)
    model = truth_model("exo_leg")
    p = IdentificationProblem.from_datasets(model, recordings(model))
    built = []
    real = problem_module.base_regressor
    monkeypatch.setattr(problem_module, "base_regressor", lambda *a, **k: built.append(1) or real(*a, **k))
    p.regressor_rows.kept = None  # from_datasets' rank check made a first pass
    first = [(r, Wk.copy()) for r, Wk in p.regressor_rows.blocks()]
    count = len(built)
    assert count > 1
    again = list(p.regressor_rows.blocks())
    assert len(built) == (count if limit else 2 * count)
    assert [r for r, _ in again] == [r for r, _ in first]
    for (_, a), (_, b) in zip(first, again):
        np.testing.assert_array_equal(a, b)
    if limit:
        assert not again[0][1].flags.writeable
        for method in ("ols", "sdp"):  # what an identification computes from them is unchanged
            q = IdentificationProblem.from_datasets(model, recordings(model))
            monkeypatch.setattr(problem_module, "KEEP_BLOCKS_BYTES", 0)
            fresh = make_result(q, make_estimator(method).fit(q), 0.0)
            monkeypatch.setattr(problem_module, "KEEP_BLOCKS_BYTES", limit)
            kept = make_result(p, make_estimator(method).fit(p), 0.0)
            np.testing.assert_array_equal(kept.base, fresh.base)
            np.testing.assert_array_equal(kept.std, fresh.std)


def test_a_pass_left_unfinished_keeps_nothing():
    model = truth_model("exo_leg")
    p = IdentificationProblem.from_datasets(model, recordings(model))
    p.regressor_rows.kept = None  # from_datasets' rank check made a first pass
    blocks = p.regressor_rows.blocks()
    next(blocks)
    blocks.close()
    assert p.regressor_rows.kept is None


def test_the_cache_key_is_the_same_before_and_after_w_is_built_and_entries_travel():
    """data_key (what RLS and the LAD reference keep their runs under) does not change when W is built, so a
    value computed in a worker and kept by the parent's cache (entries → keep) is found there."""
    from pinid.problem.cache import ProblemCache, data_key

    model = truth_model("exo_leg")
    problem = IdentificationProblem.from_datasets(model, [twin(model, seconds=4, seed=1)])
    assert problem.blocked
    key = data_key(problem)
    problem.W  # noqa: B018 -- builds W
    assert data_key(problem) == key
    other = ProblemCache()
    other.put("rls", 42, key)
    problem.cache.keep(other.entries())
    assert problem.cache.get("rls", data_key(problem)) == 42 and problem.cache.get("rls", ("else",)) is None
    with pytest.raises(TypeError, match="entries"):
        problem.cache.keep([("rls", 1)])
