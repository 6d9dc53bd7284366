"""Differential evolution: a thin wrapper of :func:`scipy.optimize.differential_evolution`.

The whole population is evaluated in one call (``vectorized=True``, ``updating="deferred"``).  The
initial population is drawn from the caller's ``rng`` (uniform in the box, so ``population`` is exact,
not scipy's ``popsize × d``), and scipy's own random stream is seeded from the same ``rng``: a fixed seed
gives identical results.  No local polish by default (``polish=False``), so that the result is what the
evolution found.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass

import numpy as np

from pinid.errors import SpecError
from pinid.progress import progress as progress_bar
from pinid.optimizers.base import Optimizer, initial_population


@dataclass
class DEOptions:
    """Settings of :class:`DifferentialEvolution` (scipy's meaning; population is the number of members)."""

    population: int = 100
    iterations: int = 200
    strategy: str = "best1bin"
    mutation: float | tuple[float, float] = (0.5, 1.0)
    recombination: float = 0.7
    tol: float = 0.0
    polish: bool = False


class DifferentialEvolution(Optimizer):
    """scipy's differential evolution, vectorised over the population."""

    name = "de"
    imports = ("scipy.optimize",)
    Options = DEOptions

    def _check_options(self) -> None:
        super()._check_options()
        if self.options.population < 5:
            raise SpecError(f"de: population {self.options.population}, expected at least 5")

    def _minimize(self, f, lower, upper, rng, x0, callback, progress):
        from scipy.optimize import differential_evolution

        o = self.options
        G = int(o.iterations)
        init = initial_population(rng, int(o.population), lower, upper, x0)
        best = {"x": init[0].copy(), "f": np.inf}

        def batch(xT: np.ndarray) -> np.ndarray:  # scipy passes (d, S)
            X = np.atleast_2d(xT.T) if xT.ndim == 2 else xT[None, :]
            values = f(X)
            k = int(np.argmin(values))
            if values[k] < best["f"]:
                best["x"], best["f"] = X[k].copy(), float(values[k])
            if "initial" not in best:  # scipy's first call evaluates the initial population
                best["initial"] = best["f"]
            return values

        history: list[float] = []
        state = {"stopped": False}
        bar = progress_bar(G, "de", enabled=progress)

        def cb(*args, **kwargs):
            history.append(best["f"])
            bar.update(1)
            bar.set_postfix_str(f"best {best['f']:.6g}", refresh=False)
            if callback is not None and callback(len(history), best["x"].copy(), best["f"]):
                state["stopped"] = True
                return True
            return False

        seed_kw = "rng" if "rng" in inspect.signature(differential_evolution).parameters else "seed"
        kwargs = {seed_kw: np.random.default_rng(rng.integers(2**63))}
        try:
            res = differential_evolution(
                batch,
                list(zip(lower, upper)),
                strategy=o.strategy,
                maxiter=G,
                popsize=1,
                tol=o.tol,
                atol=0.0,
                mutation=o.mutation,
                recombination=o.recombination,
                polish=o.polish,
                init=init,
                callback=cb,
                vectorized=True,
                updating="deferred",
                **kwargs,
            )
        finally:
            bar.close()
        if float(res.fun) <= best["f"]:
            best["x"], best["f"] = np.asarray(res.x, float), float(res.fun)
        history = [best.get("initial", best["f"])] + history  # [0]: the initial population's best
        message = "stopped by callback" if state["stopped"] else str(res.message)
        return best["x"], best["f"], history, int(res.nit), message, {}
