"""Whale optimisation (WOA) and the enhanced whale optimisation of seed 001 (EWOA).

WOA, seed 001 Eqs. (14)-(17) (Mirjalili & Lewis 2016).  Every iteration ``t = 0..G−1``,
``a = 2 − 2t/G`` decreases linearly from 2 towards 0, and each whale ``X_i`` draws ``A = 2a·r − a``
(uniform in (−a, a)), ``C = 2r'`` (uniform in (0, 2)), ``p`` uniform in [0, 1] and ``l`` uniform in [−1, 1]:

* ``p < 0.5`` and ``|A| < 1`` — encircling the prey, Eq. (15): ``X ← X_best − A·|C·X_best − X_i|``;
* ``p < 0.5`` and ``|A| ≥ 1`` — search for prey, Eq. (16): the same towards a random whale ``X_rand``;
* ``p ≥ 0.5`` — bubble-net spiral, Eq. (17): ``X ← |X_best − X_i|·e^{b·l}·cos(2πl) + X_best`` (b = ``spiral``).

``A`` and ``C`` are one number per whale, as in the reference implementation of WOA (the seed's wording
"the dimension of A is a random number" can also be read per coordinate; one number per whale is what
makes the |A| < 1 test meaningful).  New positions are clipped to the box; the best whale ever seen is
kept (elitism).

EWOA adds the differential mutation of seed 001 Eq. (18) after each WOA step::

    V_i = X_i + φ·(X_r1 − X_r2)

applied to "the better individual whales ... in the current population", and "the new mutated
individual will replace the original individual as the better one" (greedy replacement).  The seed
leaves three things open; pinid's reading, all options:

* which whales are "the better ones": the best ``mutation_fraction`` of the population (default 0.5);
* φ: a fixed ``scale`` (default 0.5, the usual differential-evolution factor);
* r1, r2: two distinct whales drawn at random from the whole population, both different from i.

The mutants cost ``mutation_fraction · population`` extra evaluations per iteration (so EWOA with
population 100 uses about 1.5× the evaluations of WOA); ``OptimizeResult.nfev`` counts them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pinid.errors import SpecError
from pinid.progress import progress as progress_bar
from pinid.optimizers.base import Optimizer, initial_population, stop_requested


@dataclass
class WOAOptions:
    """Settings of :class:`WOA` (defaults: seed 001's population 100 and 200 iterations, b = 1)."""

    population: int = 100
    iterations: int = 200
    spiral: float = 1.0
    tol: float | None = None


@dataclass
class EWOAOptions(WOAOptions):
    """Settings of :class:`EWOA`: WOA's plus the differential mutation of seed 001 Eq. (18)."""

    mutation_fraction: float = 0.5
    scale: float = 0.5


class WOA(Optimizer):
    """Whale optimisation algorithm (seed 001 Eqs. (14)-(17))."""

    name = "woa"
    Options = WOAOptions

    def _check_options(self) -> None:
        super()._check_options()
        if self.options.population < 2:
            raise SpecError(f"{self.name}: population {self.options.population}, expected at least 2")

    def _mutate(self, f, X, fX, lower, upper, rng):
        """Hook for EWOA; WOA does nothing."""
        return X, fX

    def _minimize(self, f, lower, upper, rng, x0, callback, progress):
        o = self.options
        P, G = int(o.population), int(o.iterations)
        X = initial_population(rng, P, lower, upper, x0)
        fX = f(X)
        b = int(np.argmin(fX))
        best, best_f = X[b].copy(), float(fX[b])
        history = [best_f]
        message, nit = f"{G} iterations", 0
        with progress_bar(G, self.name, enabled=progress) as bar:
            for t in range(G):
                if o.tol is not None and best_f < o.tol:
                    message = f"best value {best_f:g} < tol {o.tol:g}"
                    break
                a = 2.0 - 2.0 * t / G
                A = (2 * a * rng.random(P) - a)[:, None]
                C = (2 * rng.random(P))[:, None]
                p = rng.random(P)
                l = rng.uniform(-1.0, 1.0, P)[:, None]
                rand_idx = rng.integers(0, P, P)
                target = np.where(np.abs(A) < 1, best[None, :], X[rand_idx])  # Eq. (15) or Eq. (16)
                shrink = target - A * np.abs(C * target - X)
                spiral = np.abs(best - X) * np.exp(o.spiral * l) * np.cos(2 * np.pi * l) + best  # Eq. (17)
                X = np.clip(np.where((p < 0.5)[:, None], shrink, spiral), lower, upper)
                fX = f(X)
                X, fX = self._mutate(f, X, fX, lower, upper, rng)
                b = int(np.argmin(fX))
                if fX[b] < best_f:
                    best, best_f = X[b].copy(), float(fX[b])
                history.append(best_f)
                nit = t + 1
                bar.update(1)
                bar.set_postfix_str(f"best {best_f:.6g}", refresh=False)
                if stop_requested(callback, nit, best, best_f):
                    message = "stopped by callback"
                    break
        return best, best_f, history, nit, message, {}


class EWOA(WOA):
    """WOA plus seed 001's differential mutation of the better whales, Eq. (18), with greedy replacement."""

    name = "ewoa"
    Options = EWOAOptions

    def _check_options(self) -> None:
        super()._check_options()
        o = self.options
        if not 0 < o.mutation_fraction <= 1:
            raise SpecError(f"ewoa: mutation_fraction {o.mutation_fraction}, expected in (0, 1]")
        if o.population < 3:
            raise SpecError(f"ewoa: population {o.population}, expected at least 3 (Eq. (18) needs r1 ≠ r2 ≠ i)")

    def _mutate(self, f, X, fX, lower, upper, rng):
        o = self.options
        P = len(X)
        n = max(1, int(np.ceil(o.mutation_fraction * P)))
        elite = np.argsort(fX, kind="stable")[:n]
        r1, r2 = distinct_partners(rng, elite, P)
        V = np.clip(X[elite] + o.scale * (X[r1] - X[r2]), lower, upper)  # Eq. (18)
        fV = f(V)
        better = fV < fX[elite]
        X, fX = X.copy(), fX.copy()
        X[elite[better]], fX[elite[better]] = V[better], fV[better]
        return X, fX


def distinct_partners(rng: np.random.Generator, idx: np.ndarray, population: int) -> tuple[np.ndarray, np.ndarray]:
    """For each index i in ``idx``, two random indices r1 ≠ r2 in ``[0, population)``, both ≠ i (uniformly)."""
    idx = np.asarray(idx)
    n = len(idx)
    r1 = rng.integers(0, population - 1, n)
    r1 = r1 + (r1 >= idx)
    lo, hi = np.minimum(idx, r1), np.maximum(idx, r1)
    r2 = rng.integers(0, population - 2, n)
    r2 = r2 + (r2 >= lo)
    r2 = r2 + (r2 >= hi)
    return r1, r2
