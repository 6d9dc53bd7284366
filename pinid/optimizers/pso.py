"""Particle swarm optimisation as in seed 000, Eqs. (7)-(8).

Positions start uniform in the box and velocities uniform in ``[-v_max, v_max]`` (Eq. (7)), with
``v_max = velocity_fraction · (upper − lower)``.  Every iteration ``kg = 1..G``::

    w  = w_max − kg/G · (w_max − w_min)                       (linearly decreasing inertia weight)
    V  = w·V + c1·r1·(g_best − S) + c2·r2·(p_best − S)        (Eq. (8); r1, r2 uniform in [0, 1] per coordinate)
    S  = S + V

with velocities and positions that leave their range reset to the nearest bound, as the seed does.
Seed 000 pairs ``c1`` with the global best and ``c2`` with the particle's own best; with the default
c1 = c2 = 2 the order does not matter.  The run stops after G iterations, or earlier when the best value
falls below ``tol`` (seed 000's ε; None: never).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pinid.errors import SpecError
from pinid.progress import progress as progress_bar
from pinid.optimizers.base import Optimizer, initial_population, stop_requested


@dataclass
class PSOOptions:
    """Settings of :class:`PSO` (defaults: seed 001's population 100 and 200 iterations)."""

    population: int = 100
    iterations: int = 200
    w_max: float = 0.9
    w_min: float = 0.4
    c1: float = 2.0
    c2: float = 2.0
    tol: float | None = None
    velocity_fraction: float = 0.2


class PSO(Optimizer):
    """Particle swarm optimisation with a linearly decreasing inertia weight (seed 000)."""

    name = "pso"
    Options = PSOOptions

    def _check_options(self) -> None:
        super()._check_options()
        o = self.options
        if not 0 < o.velocity_fraction <= 1:
            raise SpecError(f"pso: velocity_fraction {o.velocity_fraction}, expected in (0, 1]")
        if o.w_min > o.w_max:
            raise SpecError(f"pso: w_min {o.w_min} > w_max {o.w_max}")

    def _minimize(self, f, lower, upper, rng, x0, callback, progress):
        o = self.options
        P, G, d = int(o.population), int(o.iterations), lower.size
        vmax = o.velocity_fraction * (upper - lower)
        S = initial_population(rng, P, lower, upper, x0)
        V = -vmax + rng.random((P, d)) * 2 * vmax
        fS = f(S)
        pbest, pbest_f = S.copy(), fS.copy()
        g = int(np.argmin(pbest_f))
        gbest, gbest_f = pbest[g].copy(), float(pbest_f[g])
        history = [gbest_f]
        message, nit = f"{G} iterations", 0
        with progress_bar(G, "pso", enabled=progress) as bar:
            for kg in range(1, G + 1):
                if o.tol is not None and gbest_f < o.tol:
                    message = f"best value {gbest_f:g} < tol {o.tol:g}"
                    break
                w = o.w_max - kg / G * (o.w_max - o.w_min)
                r1, r2 = rng.random((P, d)), rng.random((P, d))
                V = w * V + o.c1 * r1 * (gbest - S) + o.c2 * r2 * (pbest - S)
                V = np.clip(V, -vmax, vmax)
                S = np.clip(S + V, lower, upper)
                fS = f(S)
                better = fS < pbest_f
                pbest[better], pbest_f[better] = S[better], fS[better]
                g = int(np.argmin(pbest_f))
                if pbest_f[g] < gbest_f:
                    gbest, gbest_f = pbest[g].copy(), float(pbest_f[g])
                history.append(gbest_f)
                nit = kg
                bar.update(1)
                bar.set_postfix_str(f"best {gbest_f:.6g}", refresh=False)
                if stop_requested(callback, kg, gbest, gbest_f):
                    message = "stopped by callback"
                    break
        return gbest, gbest_f, history, nit, message, {}
