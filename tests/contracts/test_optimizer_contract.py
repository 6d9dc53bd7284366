"""The contract every registered optimiser keeps (issue 26): iterated over :data:`pinid.optimizers.OPTIMIZERS`,
so a new optimiser is checked without editing this file.  ``check_optimizer`` is also run on a toy optimiser
registered at runtime and on the worked example of docs/architecture.md ("Adding an optimiser").

The contract: the same seed gives the same result bit for bit; no candidate leaves the box; the known
minimum of a shifted quadratic is approached from the initial population; the population is evaluated in
one call per generation; the result's bookkeeping (history, nfev, fun) is consistent; ``x0`` enters the
initial population; NaN counts as the worst value.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import pytest

from pinid.optimizers import OPTIMIZERS, OptimizeResult, Optimizer, get_optimizer
from pinid.optimizers.base import initial_population, stop_requested

MINIMUM = np.array([0.7, -1.3])  # a known minimum inside the box, off its centre
LOWER, UPPER = np.array([-2.0, -3.0]), np.array([3.0, 1.0])
POPULATION, ITERATIONS = 20, 60


class Recorder:
    """A shifted quadratic that records every population it is asked for."""

    def __init__(self, nan_every: int = 0) -> None:
        self.batches: list[np.ndarray] = []
        self.nan_every = nan_every

    def __call__(self, X: np.ndarray) -> np.ndarray:
        self.batches.append(np.array(X))
        v = np.sum((X - MINIMUM) ** 2, axis=1)
        if self.nan_every:
            v[:: self.nan_every] = np.nan
        return v

    @property
    def points(self) -> np.ndarray:
        return np.vstack(self.batches)


def small(name: str) -> Optimizer:
    return get_optimizer(name, population=POPULATION, iterations=ITERATIONS)


def check_optimizer(name: str) -> None:
    """Every clause of the contract for the registered optimiser ``name``."""
    cls = OPTIMIZERS[name]
    assert issubclass(cls, Optimizer) and cls.name == name
    assert {"population", "iterations"} <= {f.name for f in fields(cls.Options)}, "the CLI sets both"
    cls()  # the default options are valid

    f1, f2 = Recorder(), Recorder()
    r1 = small(name).minimize(f1, LOWER, UPPER, rng=np.random.default_rng(7))
    r2 = small(name).minimize(f2, LOWER, UPPER, rng=7)  # an integer seed is the same seed
    assert isinstance(r1, OptimizeResult)
    # seeded determinism, bit for bit
    assert np.array_equal(r1.x, r2.x) and np.array_equal(r1.history, r2.history) and r1.nfev == r2.nfev
    assert np.array_equal(f1.points, f2.points)
    # respects the bounds: no candidate evaluated outside the box, nor returned
    pts = f1.points
    assert np.all(pts >= LOWER) and np.all(pts <= UPPER), f"{name} evaluated points outside the box"
    assert np.all(r1.x >= LOWER) and np.all(r1.x <= UPPER)
    # the whole swarm at once: one call per generation, not one per candidate
    sizes = [len(b) for b in f1.batches]
    assert max(sizes) >= POPULATION and len(sizes) <= r1.nfev / 2, f"{name}: batch sizes {sizes[:5]}…"
    assert r1.nfev == len(pts)
    # bookkeeping: best value after the initial population then per iteration, never increasing
    assert len(r1.history) == r1.nit + 1 and 1 <= r1.nit <= ITERATIONS
    assert np.all(np.diff(r1.history) <= 0)
    assert r1.fun == pytest.approx(r1.history[-1]) == pytest.approx(f1(r1.x[None])[0])
    assert r1.seconds >= 0 and isinstance(r1.message, str)
    # improves: from the best of the initial population towards the known minimum
    start = r1.history[0]
    assert r1.fun < 1e-2 * start and np.linalg.norm(r1.x - MINIMUM) < 0.1, f"{name}: {r1.x} vs {MINIMUM}"
    # a different seed gives a different search
    r3 = small(name).minimize(Recorder(), LOWER, UPPER, rng=8)
    assert not np.array_equal(r3.history, r1.history)
    # x0 enters the initial population
    r4 = small(name).minimize(Recorder(), LOWER, UPPER, rng=0, x0=MINIMUM)
    assert r4.history[0] < 1e-20 and r4.fun < 1e-20  # (de maps the box to [0, 1]: round-off)
    # NaN is the worst value, never the best
    r5 = small(name).minimize(Recorder(nan_every=2), LOWER, UPPER, rng=0)
    assert np.isfinite(r5.fun)


@pytest.mark.parametrize("name", sorted(OPTIMIZERS))
def test_every_registered_optimizer_keeps_the_contract(name):
    check_optimizer(name)


# ---------------------------------------------------------------------------------------------- a toy one
@dataclass
class ToyOptions:
    population: int = 10
    iterations: int = 20
    shrink: float = 0.8


class ShrinkingSearch(Optimizer):
    """Random search around the best point in a box shrinking by ``shrink`` per iteration (a toy)."""

    name = "toy_shrink"
    Options = ToyOptions

    def _minimize(self, f, lower, upper, rng, x0, callback, progress):
        o = self.options
        X = initial_population(rng, o.population, lower, upper, x0)
        values = f(X)
        k = int(np.argmin(values))
        best, fbest, history = X[k], values[k], [values[k]]
        width = (upper - lower) / 2
        for it in range(1, o.iterations + 1):
            width = width * o.shrink
            X = np.clip(best + rng.uniform(-1, 1, (o.population, lower.size)) * width, lower, upper)
            values = f(X)
            k = int(np.argmin(values))
            if values[k] < fbest:
                best, fbest = X[k], values[k]
            history.append(fbest)
            if stop_requested(callback, it, best, fbest):
                return best, fbest, history, it, "stopped by callback", {}
        return best, fbest, history, o.iterations, "iterations done", {}


def test_an_optimizer_registered_at_runtime_keeps_the_contract(monkeypatch):
    """Adding an optimiser is one class and one registry entry; the suite checks it unchanged."""
    monkeypatch.setitem(OPTIMIZERS, ShrinkingSearch.name, ShrinkingSearch)
    check_optimizer("toy_shrink")
    assert isinstance(get_optimizer("toy_shrink"), ShrinkingSearch)


def test_the_suite_catches_an_optimizer_that_leaves_the_box(monkeypatch):
    class Escaping(ShrinkingSearch):
        name = "toy_escape"

        def _minimize(self, f, lower, upper, rng, x0, callback, progress):
            f(np.vstack([upper + 1.0] * self.options.population))
            return super()._minimize(f, lower, upper, rng, x0, callback, progress)

    monkeypatch.setitem(OPTIMIZERS, Escaping.name, Escaping)
    with pytest.raises(AssertionError, match="outside the box"):
        check_optimizer("toy_escape")


def test_help_texts_list_the_registry(monkeypatch):
    """`pinid excite` and `pinid flex` name the optimisers from the registry, a runtime one included."""
    import argparse

    from pinid.cli import excite, flex

    monkeypatch.setitem(OPTIMIZERS, ShrinkingSearch.name, ShrinkingSearch)
    for module, action in ((excite, None), (flex, "fit")):
        parser = argparse.ArgumentParser(prog="pinid")
        module.add_arguments(parser)
        text = _help(parser, action)
        assert all(name in text for name in OPTIMIZERS), (module.__name__, text)


def _help(parser, action) -> str:
    """The help of ``parser`` or of its sub-command ``action``."""
    import argparse

    if action is None:
        return parser.format_help()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return sub.choices[action].format_help()


def architecture_example(heading: str) -> str:
    """The python block of the section ``heading`` of docs/architecture.md (its worked example; compiled
    with ``dont_inherit`` so that it runs as a file of its own, without this file's ``__future__`` import)."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "architecture.md").read_text(encoding="utf-8")
    section = text.split(f"\n## {heading}\n", 1)[1].split("\n## ", 1)[0]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def test_the_worked_example_of_docs_architecture_keeps_the_contract(monkeypatch):
    """docs/architecture.md's "Adding an optimiser" block, run as written, registers an optimiser that passes."""
    monkeypatch.setitem(OPTIMIZERS, "shrink", None)  # restored (removed) after the test
    exec(
        compile(architecture_example("Adding an optimiser"), "docs/architecture.md", "exec", dont_inherit=True),
        {"__name__": "example"},
    )
    check_optimizer("shrink")
