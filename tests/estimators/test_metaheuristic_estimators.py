"""RLS, PSO, RLS-PSO, WOA, EWOA and DE as estimators: contract, fitness, boxes, what they can and cannot do."""

from __future__ import annotations

import numpy as np
import pytest

from pinid.errors import SpecError
from pinid.identification.study import Study
from pinid.estimators import ESTIMATORS, OLS, RLS, RLSPSO, Metaheuristic, PSOEstimator, SearchBox, make_estimator
from pinid.estimators.metaheuristic import fitness_function, natural_scale, nominal_box, search_box, training_costs
from pinid.identification.run import identify
from pinid.problem.problem import IdentificationProblem

from test_identification import relative_errors, true_base, truth_model, twin

METAHEURISTICS = ["pso", "rls-pso", "woa", "ewoa", "de"]
SMALL = {"population": 20, "iterations": 30}


@pytest.fixture(scope="module")
def clean():
    """exo_leg, noise-free twin: the least-squares solution is the truth."""
    model = truth_model("exo_leg")
    return IdentificationProblem.from_datasets(model, twin(model, seconds=20, rate=100, seed=1))


@pytest.fixture(scope="module")
def noisy():
    model = truth_model("exo_leg")
    return IdentificationProblem.from_datasets(model, twin(model, seconds=20, rate=100, seed=2, noise=0.5))


def test_registry_names_and_contract(clean):
    assert {"rls", "pso", "rls-pso", "woa", "ewoa", "de"} <= set(ESTIMATORS)
    for name in ["rls"] + METAHEURISTICS:
        est = make_estimator(name, **({} if name == "rls" else SMALL))
        assert est.name == name and not hasattr(est, "base_")  # __init__ only stores settings
        assert est.fit(clean) is est
        assert est.base_.shape == (clean.nb,) and est.standard_ is None
        assert isinstance(est.info_, dict) and est.status_ == "ok"
    with pytest.raises(SpecError, match="bad settings"):
        make_estimator("pso", swarm=3)


@pytest.mark.parametrize("name", METAHEURISTICS)
def test_same_seed_same_result_history_never_increases(name, noisy):
    a = make_estimator(name, seed=3, **SMALL).fit(noisy)
    b = make_estimator(name, seed=3, **SMALL).fit(noisy)
    c = make_estimator(name, seed=4, **SMALL).fit(noisy)
    assert np.array_equal(a.base_, b.base_) and a.history_ == b.history_
    assert not np.array_equal(a.base_, c.base_)
    h = np.asarray(a.history_)
    assert len(h) == SMALL["iterations"] + 1 and np.all(np.diff(h) <= 0)
    assert h[-1] == pytest.approx(a.info_["fitness_value"])
    assert a.path_.shape == (SMALL["iterations"], noisy.nb)
    np.testing.assert_array_equal(a.path_[-1], a.base_)
    lower, upper = a.box_
    assert np.all(a.base_ >= lower) and np.all(a.base_ <= upper)


@pytest.mark.parametrize("weighted", [False, True])
def test_fitness_of_a_whole_population_matches_the_direct_sums(noisy, weighted):
    p = noisy
    if weighted:
        p = IdentificationProblem(
            **{
                **{k: getattr(noisy, k) for k in ("model", "terms", "base", "W", "tau", "joint", "sample", "nominal")},
                "weights": np.random.default_rng(0).uniform(0.5, 2.0, noisy.rows),
            }
        )
    X = p.nominal_base + np.random.default_rng(1).normal(size=(7, p.nb)) * 0.1
    r = p.tau[None, :] - X @ p.W.T
    w = p.weights
    np.testing.assert_allclose(fitness_function(p, "sse")(X), 0.5 * np.sum(w * r**2, axis=1), rtol=1e-9)
    np.testing.assert_allclose(fitness_function(p, "sae")(X), np.sum(np.sqrt(w) * np.abs(r), axis=1), rtol=1e-12)
    costs = training_costs(p, X[0])
    assert costs["sse"] == pytest.approx(0.5 * np.sum(w * r[0] ** 2)) and costs["sae"] > 0
    with pytest.raises(SpecError, match="fitness 'mse'"):
        fitness_function(p, "mse")


def test_pso_on_noise_free_twin_data_converges_toward_least_squares(clean):
    ls = OLS().fit(clean).base_
    _, truth = true_base(clean.model)
    assert relative_errors(clean.model, ls, truth).max() < 1e-6
    errors = []
    for iterations in (20, 100, 400):
        est = PSOEstimator(population=40, iterations=iterations, seed=0).fit(clean)
        errors.append(relative_errors(clean.model, est.base_, ls).max())
        assert est.info_["fitness_value"] >= est.info_["ls_fitness"]
    assert errors[0] > errors[1] > errors[2]
    assert errors[2] < 1e-3, errors


@pytest.mark.parametrize("name", METAHEURISTICS)
def test_nothing_fits_the_training_data_better_than_least_squares_on_squared_error(name, noisy):
    ls_cost = training_costs(noisy, OLS().fit(noisy).base_)["sse"]
    est = make_estimator(name, **SMALL).fit(noisy)
    assert est.info_["train_costs"]["sse"] >= ls_cost * (1 - 1e-12)
    assert est.info_["ls_train_costs"]["sse"] == pytest.approx(ls_cost)


def test_rls_with_forgetting_one_ends_at_batch_least_squares(noisy):
    ls = OLS().fit(noisy).base_
    rls = RLS().fit(noisy)
    np.testing.assert_allclose(rls.base_, ls, rtol=1e-9)
    np.testing.assert_allclose(RLS(init="prior").fit(noisy).base_, ls, rtol=1e-5)  # the textbook start: a tiny ridge
    assert rls.estimates_.shape == (noisy.rows, noisy.nb)
    np.testing.assert_array_equal(rls.estimates_[-1], rls.base_)
    lower, upper = rls.box_
    skip = rls.info_["burn_in_rows"]
    assert skip == round(0.1 * noisy.rows)
    np.testing.assert_array_equal(lower, rls.estimates_[skip:].min(axis=0))
    assert np.all(lower <= rls.base_) and np.all(rls.base_ <= upper)
    wide = RLS(widen=0.5).fit(noisy)
    np.testing.assert_allclose(wide.box_[1] - wide.box_[0], 2 * (upper - lower))
    assert len(rls.history_) == 10 and set(rls.info_["box"]) == {"lower", "upper"}


def test_rls_forgetting_tracks_a_change_that_plain_rls_averages(noisy):
    """Second half of the rows with every parameter scaled by 1.2: λ < 1 ends near the new values."""
    p = noisy
    x = OLS().fit(p).base_
    half = p.rows // 2
    tau = np.concatenate([p.W[:half] @ x, p.W[half:] @ (1.2 * x)])
    q = IdentificationProblem(p.model, p.terms, p.base, p.W, tau, p.joint, p.sample, p.weights, p.nominal)
    plain = RLS().fit(q).base_
    forgetting = RLS(forgetting=0.995).fit(q).base_
    assert np.abs(forgetting / x - 1.2).max() < 1e-3  # the first half weighs λ^rows/2 ≈ 4e-5
    assert np.abs(plain / x - 1.2).max() > 0.05


def test_rls_settings_are_checked(noisy):
    for bad in (
        {"forgetting": 0.0},
        {"forgetting": 1.5},
        {"p0": -1},
        {"burn_in": 10**9},
        {"init": "prior", "x0": "mean"},
        {"init": "warm"},
    ):
        with pytest.raises(SpecError, match="rls"):
            RLS(**bad).fit(noisy)
    start = RLS(init="prior", x0="nominal", burn_in=0).fit(noisy)
    assert start.info_["burn_in_rows"] == 0


def test_rls_pso_searches_the_rls_box(noisy):
    rls = RLS(burn_in=0.2).fit(noisy)
    est = RLSPSO(box=SearchBox(rls={"burn_in": 0.2}), **SMALL).fit(noisy)
    np.testing.assert_array_equal(est.box_[0], rls.box_[0])
    np.testing.assert_array_equal(est.box_[1], rls.box_[1])
    assert est.info_["box"]["kind"] == "rls" and est.info_["optimizer"] == "pso"


def test_default_box_is_around_the_urdf_and_options_override_it(noisy):
    p = noisy
    lower, upper = nominal_box(p)
    x = p.nominal_base
    half = np.maximum(np.abs(x), 0.5 * natural_scale(p))
    np.testing.assert_allclose(lower, x - half)
    np.testing.assert_allclose(upper, x + half)
    name = p.names[0]
    lo, hi, info = search_box(p, {name: (-1.0, 2.0)})
    assert (lo[0], hi[0]) == (-1.0, 2.0) and np.allclose(lo[1:], lower[1:])
    lo, hi, _ = search_box(p, (lower - 1, upper + 1))
    np.testing.assert_allclose(hi - lo, upper - lower + 2)
    lo, hi, info = search_box(p, "ls")
    assert info["kind"] == "ls" and np.all(lo < OLS().fit(p).base_) and np.all(OLS().fit(p).base_ < hi)
    for bad in ("sphere", {"nope": (0, 1)}, (upper, lower), (lower[:3], upper[:3])):
        with pytest.raises(SpecError, match="box"):
            search_box(p, bad)
    with pytest.raises(SpecError, match="box_width"):
        nominal_box(p, 0.0, 0.0)


def test_the_box_is_one_setting_and_its_flat_spelling_still_works(noisy):
    """``box`` is a SearchBox (kind, width, floor, rls); ``make_estimator`` (so ``--option`` and ``pinid
    compare``'s flags) also takes its fields as box_width, box_floor and rls, with the same result, bit for
    bit; a bad one is a one-line SpecError naming the method and the field."""
    flat = make_estimator("pso", box="ls", box_width=0.5, seed=2, **SMALL)
    assert flat.box == SearchBox("ls", width=0.5) and set(flat.get_params()) == set(Metaheuristic.settings)
    grouped = PSOEstimator(box=SearchBox("ls", width=0.5), seed=2, **SMALL)
    np.testing.assert_array_equal(flat.fit(noisy).base_, grouped.fit(noisy).base_)
    rls = make_estimator("rls-pso", rls={"burn_in": 0.2}, box_floor=0.1, **SMALL)
    assert rls.box == SearchBox(floor=0.1, rls={"burn_in": 0.2}) and rls.fit(noisy).info_["box"]["kind"] == "rls"
    assert make_estimator("woa", box="rls").box == SearchBox("rls")
    for bad, fragment in (({"box_width": -1.0}, "width=-1.0"), ({"rls": 3}, "rls"), ({"box": 3.0}, "kind")):
        with pytest.raises(SpecError, match=f"method 'pso': SearchBox {fragment}"):
            make_estimator("pso", **bad)
    with pytest.raises(SpecError, match="bad settings"):
        make_estimator("pso", progress=False)  # not a setting of the estimate: pinid.progress.choose


def test_tol_stops_early_like_seed_000s_epsilon(noisy):
    first = PSOEstimator(**SMALL).fit(noisy).history_[0]
    est = PSOEstimator(population=20, iterations=500, tol=first * 0.999).fit(noisy)
    assert len(est.history_) < 501 and "tol" in est.info_["message"]


def test_sae_fitness_heads_for_the_least_absolute_deviations_fit(noisy):
    from pinid.identification.compare import lad

    x_lad = lad(noisy)
    sae = training_costs(noisy, x_lad)["sae"]
    assert sae <= training_costs(noisy, OLS().fit(noisy).base_)["sae"]
    est = PSOEstimator(fitness="sae", population=30, iterations=150, box="ls").fit(noisy)
    assert sae <= est.info_["fitness_value"] <= 1.01 * sae


def test_identify_runs_the_metaheuristics_through_the_common_result(noisy):
    model = noisy.model
    train = twin(model, seconds=20, rate=100, seed=2, noise=0.5)
    valid = twin(model, seconds=8, rate=100, seed=3, noise=0.5)
    res = identify(
        Study(model, train, validate=valid), methods=["ols", "pso", "rls-pso"], options={"pso": SMALL, "rls-pso": SMALL}
    )
    for m in ("pso", "rls-pso"):
        r = res[m]
        assert r.history and len(r.history) == SMALL["iterations"] + 1
        assert r.standard_source in ("consistent completion", "least-norm completion")
        assert r.validation is not None and r.info["optimizer"] == "pso"
        assert r.settings["population"] == 20
        assert r.train.all["rms"] >= res["ols"].train.all["rms"] * (1 - 1e-12)
    assert issubclass(ESTIMATORS["woa"], Metaheuristic)


def test_bad_settings_are_clean_errors(clean):
    with pytest.raises(SpecError, match="own setting"):
        make_estimator("pso", options={"population": 5}, **SMALL).fit(clean)
    with pytest.raises(SpecError, match="pair"):
        make_estimator("pso", box={clean.names[0]: 3.0}, **SMALL).fit(clean)
    with pytest.raises(SpecError, match="rls"):
        make_estimator("rls-pso", rls={"nonsense": 1}, **SMALL).fit(clean)
    with pytest.raises(SpecError, match="x0 has"):
        make_estimator("rls", x0=[1.0, 2.0]).fit(clean)


def test_de_history_starts_at_the_initial_population(clean):
    est = make_estimator("de", **SMALL).fit(clean)
    assert est.history_[0] > est.history_[-1]
    assert est.history_[0] >= est.history_[1]


def test_an_rls_run_is_kept_in_the_problem_for_its_settings(monkeypatch):
    """Issue 35: the rls method and RLS-PSO's box on the same problem run the recursion once; another
    setting, or another problem, runs it again; the kept run gives what a new run gives."""
    model = truth_model("exo_leg")
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=10, rate=100, seed=3, noise=0.5))
    runs = []
    real = RLS._run
    monkeypatch.setattr(RLS, "_run", lambda self, *a: runs.append(1) or real(self, *a))
    first = RLS().fit(problem)
    box = RLSPSO(**SMALL).fit(problem).box_
    again = RLS().fit(problem)
    assert len(runs) == 1
    np.testing.assert_array_equal(box[0], first.box_[0])
    for name in ("base_", "estimates_"):
        np.testing.assert_array_equal(getattr(again, name), getattr(first, name))
    assert again.info_ == first.info_ and again.history_ == first.history_
    again.base_[0] = 1e9  # a caller changing its result does not change what the problem keeps
    np.testing.assert_array_equal(RLS().fit(problem).base_, first.base_)
    RLS(burn_in=0.2).fit(problem)
    assert len(runs) == 2
    other = IdentificationProblem.from_datasets(model, twin(model, seconds=10, rate=100, seed=3, noise=0.5))
    np.testing.assert_array_equal(RLS().fit(other).base_, first.base_)  # the same data, a new run
    assert len(runs) == 3
