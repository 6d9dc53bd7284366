"""Every estimator of the registry, checked the same way: the contract of pinid.estimators.base.

A new estimator (one file + one registry line) is picked up here without editing this file.
"""

from __future__ import annotations

import numpy as np
import pytest

from pinid.errors import SpecError
from pinid.estimators import ESTIMATORS, Estimator, Setting, make_estimator
from pinid.problem.problem import IdentificationProblem, Problem

from test_identification import relative_errors, true_base, truth_model, twin

#: Small settings for the population methods, applied where an estimator has these settings.
FAST = {"population": 12, "iterations": 6}


@pytest.fixture(scope="module")
def clean():
    """A noise-free recording of the exo leg (friction included) and its true base parameters."""
    model = truth_model("exo_leg")
    problem = IdentificationProblem.from_datasets(model, twin(model, seconds=6, rate=100, seed=3))
    assert isinstance(problem, Problem)
    return problem, true_base(model)[1]


def fast(cls) -> dict:
    return {k: v for k, v in FAST.items() if k in cls.settings}


@pytest.fixture(scope="module")
def fitted(clean) -> dict:
    """One fit per estimator with its small settings (seed 5 where it has one), shared by the tests that only
    read it: ``name -> (estimator, its attributes before fit, whether fit returned it)``.  DIDIM's fit alone costs about 2 s."""
    problem, _ = clean
    cache: dict = {}

    def get(name: str):
        if name not in cache:
            cls = ESTIMATORS[name]
            est = make_estimator(name, **fast(cls), **({"seed": 5} if "seed" in cls.settings else {}))
            before = set(vars(est))
            cache[name] = (est, before, est.fit(problem) is est)
        return cache[name]

    return get


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_class_declares_what_the_rest_needs(name):
    cls = ESTIMATORS[name]
    assert issubclass(cls, Estimator) and cls.name == name and cls.description
    assert (
        isinstance(cls.deterministic, bool)
        and isinstance(cls.exact, bool)
        and cls.history in ("none", "passes", "rows", "fitness")
    )
    assert cls.colour is None or isinstance(cls.colour, str)
    params = cls().get_params()
    assert set(cls.settings) == set(params), "every __init__ setting has a Setting (types, range) and no other"
    for key, spec in cls.settings.items():
        assert isinstance(spec, Setting)
        assert spec.check(name, key, params[key]) == params[key], f"the default of {key} passes its own check"


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_lazy_imports_and_shared_work_are_what_a_study_can_use(name):
    """lazy_imports() names modules that import (a study imports them before forking its workers), and
    shared_work() gives hashable (method, settings) fits of registered methods (run once per study)."""
    import importlib

    est = make_estimator(name)
    for module in est.lazy_imports():
        importlib.import_module(module)
    for method, settings in est.shared_work():
        assert method in ESTIMATORS and hash((method, settings)) is not None
        make_estimator(method, **dict(settings))


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_init_only_stores_settings_and_they_round_trip(name):
    est = make_estimator(name, **fast(ESTIMATORS[name]))
    params = est.get_params()
    assert vars(est) == params, "__init__ stores its settings as they are, nothing else"
    again = make_estimator(name, **params)
    assert again.get_params() == params
    assert repr(again) == repr(est)


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_bad_settings_are_spec_errors_at_construction(name):
    cls = ESTIMATORS[name]
    with pytest.raises(SpecError, match=f"method '{name}': bad settings"):
        make_estimator(name, no_such_setting=1)
    for key, spec in cls.settings.items():
        bad = (
            "not a number"
            if spec.kind in ("int", "float", "bool", "dict")
            else ("no such choice" if spec.choices else None)
        )
        if bad is not None:
            with pytest.raises(SpecError, match=f"method '{name}': setting {key}="):
                make_estimator(name, **{key: bad})


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_fit_returns_self_and_fitted_attributes_end_in_underscore(name, clean, fitted):
    problem, _ = clean
    est, before, returned_self = fitted(name)
    assert returned_self
    added = set(vars(est)) - before
    assert added and all(k.endswith("_") for k in added), sorted(added)
    assert est.base_.shape == (problem.nb,) and np.all(np.isfinite(est.base_))
    assert est.standard_ is None or est.standard_.shape == (len(problem.standard_names),)
    assert isinstance(est.info_, dict) and isinstance(est.status_, str)
    assert est.history_ is None or all(isinstance(h, float) for h in est.history_)


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_same_settings_same_result(name, clean, fitted):
    """Seeded reproducibility: the same settings (seed included) give the same parameters, bit for bit (a new
    estimator against the shared fit of the same settings)."""
    problem, _ = clean
    first, _, _ = fitted(name)
    again = make_estimator(name, **first.get_params()).fit(problem)
    np.testing.assert_array_equal(again.base_, first.base_)


@pytest.mark.parametrize("name", [m for m, cls in ESTIMATORS.items() if cls.deterministic])
def test_deterministic_methods_recover_noise_free_parameters(name, clean):
    problem, truth = clean
    est = make_estimator(name).fit(problem)
    err = relative_errors(problem.model, est.base_, truth)
    # an estimator that simulates the model between samples (DIDIM) is exact only up to that simulation
    assert err.max() < (1e-5 if ESTIMATORS[name].exact else 2e-2), dict(zip(problem.names, err))


def test_ridge_between_least_squares_and_its_prior(clean):
    """The worked example of docs/architecture.md: alpha 0 is OLS; a huge alpha returns the prior."""
    problem, _ = clean
    ols = make_estimator("ols").fit(problem).base_
    np.testing.assert_allclose(make_estimator("ridge", alpha=0.0).fit(problem).base_, ols, rtol=1e-9, atol=1e-12)
    far = make_estimator("ridge", alpha=1e12, prior="zero").fit(problem).base_
    assert np.abs(far).max() < 1e-6 * np.abs(ols).max()


@pytest.mark.slow
def test_cli_option_reaches_the_estimator_and_bad_settings_exit_2(tmp_path, clean):
    from conftest import assert_clean_error, run_cli
    from pinid.data.formats import write_recording

    model = truth_model("exo_leg")
    write_recording(tmp_path / "run.csv", twin(model, seconds=4, rate=100, seed=4, noise=0.05))
    args = ["identify", "--urdf", "exo_leg", "--data", str(tmp_path / "run.csv"), "--no-report"]
    proc = run_cli(
        *args,
        "--methods",
        "ols,wls,ridge",
        "--option",
        "wls.iterations=3",
        "--option",
        "ridge.prior=zero",
        "-o",
        str(tmp_path / "ok"),
    )
    assert proc.returncode == 0, proc.stderr
    import json

    d = json.loads((tmp_path / "ok" / "identification.json").read_text())
    assert d["methods"]["wls"]["settings"]["iterations"] == 3 and d["methods"]["ridge"]["settings"]["prior"] == "zero"
    for option, fragment in (
        ("wls.iterations=0", "iterations=0"),
        ("ridge.prior=urdf", "prior='urdf'"),
        ("sdp.regularization=1", "not run"),
        ("wls.speed=3", "bad settings"),
        ("wls=3", "METHOD.KEY=VALUE"),
    ):
        proc = run_cli(*args, "--methods", "ols,wls,ridge", "--option", option, "-o", str(tmp_path / "bad"))
        assert_clean_error(proc, fragment)
    assert not (tmp_path / "bad").exists() or not any((tmp_path / "bad").iterdir())


def test_every_method_defaults_leave_out_the_simulating_estimators():
    """pinid compare and pinid demo run every registered method by default but those that simulate the robot
    (iv, didim: tens of seconds each on a long recording); "all" still names every one."""
    from pinid.estimators import ESTIMATORS, quick_methods
    from pinid.identification.run import parse_methods

    simulating = {name for name, cls in ESTIMATORS.items() if cls.simulates}
    assert simulating == {"iv", "didim"}
    assert quick_methods() == [m for m in ESTIMATORS if m not in simulating and ESTIMATORS[m].in_defaults]
    assert "essential" not in quick_methods()  # left out by choice: the demo's figures stay those of its 12 fits
    assert "logdet" not in quick_methods()  # its weight cross-validated: seconds per fit
    assert parse_methods("all") == list(ESTIMATORS)
