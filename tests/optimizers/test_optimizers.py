"""Population optimisers: they find known minima in a box, deterministically, through one interface."""

from __future__ import annotations

import numpy as np
import pytest

from pinid.errors import SolverError, SpecError
from pinid.optimizers import OPTIMIZERS, OptimizeResult, Optimizer, PSOOptions, get_optimizer
from pinid.optimizers.woa import distinct_partners

SHIFT = np.array([0.7, -1.3, 2.1])
LOWER, UPPER = -np.full(3, 4.0), np.full(3, 4.0)


def sphere(X):
    return np.sum((X - SHIFT) ** 2, axis=1)


def rosenbrock(X):
    return np.sum(100 * (X[:, 1:] - X[:, :-1] ** 2) ** 2 + (1 - X[:, :-1]) ** 2, axis=1)


# tolerance on |x - x*| per method: WOA is the weakest on shifted functions (it is known to favour the origin)
TOL = {"pso": 1e-4, "woa": 5e-2, "ewoa": 5e-2, "de": 1e-4}


def test_registry_has_the_seed_methods():
    assert {"pso", "woa", "ewoa", "de"} <= set(OPTIMIZERS)
    for name, cls in OPTIMIZERS.items():
        assert issubclass(cls, Optimizer) and cls.name == name


@pytest.mark.parametrize("name", ["pso", "woa", "ewoa", "de"])
def test_finds_the_minimum_of_a_shifted_sphere_deterministically(name):
    opt = get_optimizer(name, population=30, iterations=150)
    r1 = opt.minimize(sphere, LOWER, UPPER, rng=np.random.default_rng(3))
    r2 = opt.minimize(sphere, LOWER, UPPER, rng=np.random.default_rng(3))
    assert isinstance(r1, OptimizeResult)
    np.testing.assert_allclose(r1.x, SHIFT, atol=TOL[name])
    # same seed, same result, bit for bit
    assert np.array_equal(r1.x, r2.x) and np.array_equal(r1.history, r2.history)
    # history: best value after the initial population then after every iteration, never increasing
    assert len(r1.history) == r1.nit + 1 and r1.nit == 150
    assert np.all(np.diff(r1.history) <= 0) and r1.history[-1] == pytest.approx(r1.fun)
    assert r1.fun == pytest.approx(sphere(r1.x[None])[0])
    assert r1.nfev >= 30 * 151 and r1.seconds >= 0
    np.testing.assert_array_less(LOWER - 1e-12, r1.x)
    np.testing.assert_array_less(r1.x, UPPER + 1e-12)


@pytest.mark.parametrize("name", ["pso", "ewoa", "de"])
def test_rosenbrock_in_a_box(name):
    opt = get_optimizer(name, population=40, iterations=400)
    res = opt.minimize(rosenbrock, -2 * np.ones(2), 2 * np.ones(2), rng=5)
    np.testing.assert_allclose(res.x, [1.0, 1.0], atol=0.05)


def test_minimum_on_the_boundary_of_the_box():
    for name in ("pso", "de"):
        res = get_optimizer(name, population=20, iterations=80).minimize(sphere, np.zeros(3), np.ones(3), rng=0)
        np.testing.assert_allclose(res.x, [0.7, 0.0, 1.0], atol=1e-4)


def test_different_seeds_differ_and_integer_seed_is_accepted():
    opt = get_optimizer("woa", population=10, iterations=5)
    a = opt.minimize(sphere, LOWER, UPPER, rng=1)
    b = opt.minimize(sphere, LOWER, UPPER, rng=2)
    c = opt.minimize(sphere, LOWER, UPPER, rng=np.random.default_rng(1))
    assert not np.array_equal(a.x, b.x)
    assert np.array_equal(a.x, c.x)


def test_x0_enters_the_initial_population():
    res = get_optimizer("pso", population=5, iterations=1).minimize(sphere, LOWER, UPPER, rng=0, x0=SHIFT)
    assert res.history[0] == 0.0 and res.fun == 0.0


def test_callback_stops_and_tol_stops_pso():
    calls = []
    res = get_optimizer("ewoa", population=10, iterations=50).minimize(
        sphere, LOWER, UPPER, rng=0, callback=lambda it, x, f: calls.append(it) or it >= 3
    )
    assert calls == [1, 2, 3] and res.nit == 3 and "callback" in res.message
    res = get_optimizer("pso", PSOOptions(population=30, iterations=500, tol=1e-3)).minimize(
        sphere, LOWER, UPPER, rng=0
    )
    assert res.fun < 1e-3 and res.nit < 500


def test_nan_counts_as_worst_and_bad_shapes_are_caught():
    def f(X):
        v = sphere(X)
        v[::2] = np.nan
        return v

    res = get_optimizer("pso", population=10, iterations=20).minimize(f, LOWER, UPPER, rng=0)
    assert np.isfinite(res.fun)
    with pytest.raises(SolverError, match="expected"):
        get_optimizer("woa", population=4, iterations=2).minimize(lambda X: np.zeros(3), LOWER, UPPER, rng=0)


def test_ewoa_partners_are_distinct():
    rng = np.random.default_rng(0)
    idx = np.repeat(np.arange(5), 2000)
    r1, r2 = distinct_partners(rng, idx, 5)
    assert np.all(r1 != idx) and np.all(r2 != idx) and np.all(r1 != r2)
    assert set(np.unique(r1)) == set(range(5)) and set(np.unique(r2)) == set(range(5))


def test_ewoa_mutation_costs_extra_evaluations():
    w = get_optimizer("woa", population=20, iterations=10).minimize(sphere, LOWER, UPPER, rng=0)
    e = get_optimizer("ewoa", population=20, iterations=10, mutation_fraction=0.5).minimize(sphere, LOWER, UPPER, rng=0)
    assert w.nfev == 20 * 11 and e.nfev == 20 * 11 + 10 * 10


def test_bad_names_options_and_bounds_are_clear_errors():
    with pytest.raises(SpecError, match="unknown optimizer 'nope'"):
        get_optimizer("nope")
    with pytest.raises(SpecError, match="unknown option.*swarm"):
        get_optimizer("pso", swarm=3)
    with pytest.raises(SpecError, match="population"):
        get_optimizer("de", population=0)
    with pytest.raises(SpecError, match="lower bound"):
        get_optimizer("pso").minimize(sphere, np.ones(3), np.zeros(3))
    with pytest.raises(SpecError, match="finite"):
        get_optimizer("pso").minimize(sphere, LOWER, np.full(3, np.inf))
