"""Metaheuristic estimators: PSO, RLS-PSO, WOA, EWOA and differential evolution on the base parameters.

Each estimator searches the nb base parameters inside a box with a population optimiser of
:mod:`pinid.optimizers` (seed 000 Eqs. (7)-(8); seed 001 Eqs. (14)-(18); scipy's
``differential_evolution``), minimising one of two fitness functions of the torque residual
``r = τ − W_b·x`` over the training rows (row weights ``w``, ones unless given):

``"sse"``  ½·Σ w·r²  — seed 001 Eq. (22).  Evaluated for the whole swarm at once in the compressed
           form ``½(‖R·(s∘x) − c‖² + ρ²)`` (:func:`~pinid.linalg.augmented_r`: R is nb × nb),
           so an iteration costs one (P × nb)·(nb × nb) product whatever the number of samples, and
           there is no cancellation near the minimum.
``"sae"``  Σ √w·|r|  — seed 000 (its PSO minimises the sum of absolute torque errors, "ΔT1 + ΔT2").
           Needs the tall product ``W·Xᵀ`` (rows × P) every iteration, computed in chunks of rows.

**Least squares is the global minimiser of "sse"** on the training data (docs/metaheuristics.md): none of
these estimators can reach a lower "sse" than :class:`~pinid.estimators.ols.OLS`; with "sae" they aim at
the least-absolute-deviations fit (:func:`least_absolute_deviations`, convex, found deterministically
by IRLS) instead.  Every result reports both training costs, the least-squares value of its fitness
(``info_["ls_fitness"]``) and the global minimum of its fitness (``info_["min_fitness"]``), so that the
distance to the optimum is visible.

The search box
--------------
The seeds do not give a usable box (seed 000's plain PSO searches an "infinite domain", which cannot be
sampled).  ``box``, a :class:`SearchBox` (``kind``, ``width``, ``floor``, ``rls``; or its kind alone), chooses
it; ``make_estimator`` and ``--option`` also take its fields as the flat settings ``box_width``,
``box_floor`` and ``rls`` (:data:`BOX_SETTINGS`).  Its kind:

``"nominal"`` (default)  the URDF's base parameters ``x_nom`` ± ``max(width·|x_nom|, floor·s)``,
                         ``s`` the natural magnitude of each base parameter (its standard combination
                         with mass M, first moments M·L, inertias M·L² of each body,
                         :func:`pinid.model.physical.parameter_scale`; 1 for friction).  Defaults
                         ``width = 1`` (±100 %) and ``floor = 0.5``.  It uses only prior
                         knowledge, never the data.
``"rls"``                each parameter's [min, max] of a recursive least-squares run on the same data
                         (:class:`~pinid.estimators.rls.RLS`, settings in ``rls``), seed 000's RLS-PSO.
``"ls"``                 the least-squares estimate ± ``width``·(its standard deviation)·10 — circular
                         (the box is centred on the answer of the method it is compared with); for
                         experiments only.
``(lower, upper)``       explicit arrays (nb each), or a dict ``{name: (lo, hi)}`` overriding the nominal box.

The settings ``population`` (100) and ``iterations`` (200) are seed 001's; ``seed`` seeds the
optimiser's ``numpy.random.Generator`` (same seed → same result, bit for bit); ``tol`` stops when the
best fitness falls below it (seed 000's ε); ``options`` passes the optimiser's own settings (PSO's
``w_max``, ``w_min``, ``c1``, ``c2``; WOA's ``spiral``; EWOA's ``mutation_fraction`` and ``scale``; …).
The progress bar is not a setting of the estimate: it follows :mod:`pinid.progress` (``with
pinid.progress.choose(False): est.fit(problem)`` hides it).

Fitted values: ``base_``; ``history_`` (best fitness after the initial population and after every
iteration); ``path_`` (iterations, nb): the best particle after each iteration (seed 000 Figs. 8,
11); ``box_``; ``info_`` (optimiser, evaluations, iterations, stop message, box, the fitness reached,
both training costs and the least-squares ones).
"""

from __future__ import annotations


import math
import numbers
import time
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from pinid.errors import SpecError
from pinid.problem.cache import data_key
from pinid.estimators.base import Estimator, Setting
from pinid.estimators.rls import RLS
from pinid.problem.problem import Problem
from pinid.problem.statistics import base_statistics
from pinid.linalg import solve_r, weighted_lstsq
from pinid.optimizers import OPTIMIZERS, get_optimizer

#: Fitness functions: name -> description.
FITNESS = {"sse": "½·Σ r² (seed 001 Eq. (22))", "sae": "Σ |r| (seed 000)"}
_CHUNK_ELEMENTS = (
    500_000  # particles × rows per block of the "sae" product (4 MB: stays in cache; 2.5× faster than 16 MB)
)


# ------------------------------------------------------------------------------------------- helpers
def natural_scale(problem) -> np.ndarray:
    """Natural magnitude of every base parameter (nb,): ``|P|·s`` with ``s`` = per body M, M·L, M·L²
    (:func:`pinid.model.physical.parameter_scale`, from the nominal parameters) and 1 for joint terms.
    Every :class:`~pinid.problem.problem.Problem` provides it as ``problem.natural_scale``."""
    return np.asarray(problem.natural_scale, dtype=float)


def fitness_function(problem, kind: str = "sse"):
    """The batch fitness ``f(X) -> (P,)`` of a population ``X (P, nb)`` on ``problem`` (see the module text)."""
    if kind == "sse":
        R, c, rho, scale = problem.compressed()
        RT = np.ascontiguousarray(R.T)
        rho2 = rho * rho

        def sse(X: np.ndarray) -> np.ndarray:
            E = (X * scale) @ RT - c
            return 0.5 * (np.einsum("ij,ij->i", E, E) + rho2)

        return sse
    if kind == "sae":
        WT = np.ascontiguousarray(np.asarray(problem.W, dtype=float).T)  # particle-major residuals below
        tau = np.asarray(problem.tau, dtype=float)
        w = np.asarray(problem.weights, dtype=float) if problem.weights is not None else None
        sw = None if w is None or np.all(w == 1.0) else np.sqrt(w)
        rows = len(tau)

        def sae(X: np.ndarray) -> np.ndarray:
            P = len(X)
            out = np.zeros(P)
            step = max(1, _CHUNK_ELEMENTS // max(P, 1))
            for start in range(0, rows, step):
                stop = min(rows, start + step)
                E = X @ WT[:, start:stop]  # (P, block): each particle's residuals contiguous
                E -= tau[start:stop]
                np.abs(E, out=E)
                out += (E @ sw[start:stop]) if sw is not None else E.sum(axis=1)
            return out

        return sae
    raise SpecError(f"fitness {kind!r}, expected one of {', '.join(FITNESS)}")


def training_costs(problem, x: np.ndarray) -> dict:
    """``{"sse": ½Σw·r², "sae": Σ√w·|r|}`` of base parameters ``x`` on the problem's rows."""
    r = np.asarray(problem.tau) - np.asarray(problem.W) @ np.asarray(x, dtype=float)
    w = np.asarray(problem.weights, dtype=float) if problem.weights is not None else np.ones(len(r))
    return {"sse": float(0.5 * np.sum(w * r * r)), "sae": float(np.sum(np.sqrt(w) * np.abs(r)))}


def least_squares(problem) -> np.ndarray:
    """The (weighted) least-squares base parameters of the problem: the global minimum of "sse"."""
    R, c, _, scale = problem.compressed()
    return solve_r(R, c, scale)


def cached_lad(problem) -> np.ndarray:
    """:func:`least_absolute_deviations` of ``problem``, kept in its ``cache`` (a
    :class:`~pinid.problem.cache.ProblemCache`, when it has one): every seed of a comparison needs it."""
    key = data_key(problem)
    cache = getattr(problem, "cache", None)
    kept = None if cache is None else cache.get("lad", key)
    if kept is None:
        kept = least_absolute_deviations(problem)
        if cache is not None:
            cache.put("lad", kept, key)
    return kept


def least_absolute_deviations(problem, iterations: int = 200, tol: float = 1e-12) -> np.ndarray:
    """Least-absolute-deviations base parameters, ``argmin Σ √w·|τ − W x|`` — the global minimum of "sae" —
    by iteratively reweighted least squares from the least-squares solution (weights
    ``√w / max(|r|, 1e-9·RMS(r))``; the cost is convex, so this converges to its minimum)."""
    W, tau = np.asarray(problem.W), np.asarray(problem.tau)
    sw = np.sqrt(np.asarray(problem.weights, float)) if problem.weights is not None else np.ones(len(tau))
    x = least_squares(problem)
    cost = float(np.sum(sw * np.abs(tau - W @ x)))
    for _ in range(iterations):
        r = tau - W @ x
        eps = 1e-9 * max(float(np.sqrt(np.mean(r * r))), 1e-300)
        x_new = weighted_lstsq(W, tau, sw / np.maximum(np.abs(r), eps))
        new = float(np.sum(sw * np.abs(tau - W @ x_new)))
        if new > cost:
            break
        done = cost - new <= tol * max(cost, 1e-300)
        x, cost = x_new, new
        if done:
            break
    return x


def nominal_box(problem, width: float = 1.0, floor: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """``x_nom ± max(width·|x_nom|, floor·s)`` (see the module text)."""
    if not width >= 0 or not floor >= 0 or (width == 0 and floor == 0):
        raise SpecError(f"box_width {width!r} and box_floor {floor!r}: expected ≥ 0, not both 0")
    x = np.asarray(problem.nominal_base, dtype=float)
    half = np.maximum(width * np.abs(x), floor * natural_scale(problem))
    half = np.maximum(half, 1e-9 * np.maximum(natural_scale(problem), 1e-300))
    return x - half, x + half


def search_box(problem, box="nominal", *, width: float = 1.0, floor: float = 0.5, rls: dict | None = None):
    """``(lower, upper, info)``: the search box the settings describe (module text)."""
    nb = problem.nb
    names = list(problem.names)
    info: dict = {}
    if isinstance(box, str):
        kind = box.lower()
        if kind == "nominal":
            lower, upper = nominal_box(problem, width, floor)
        elif kind == "rls":
            est = RLS.create(**dict(rls or {})).fit(problem)  # bad settings: SpecError; the run is cached (RLS.fit)
            lower, upper = est.box_
            info["rls"] = {
                "final": dict(zip(names, map(float, est.base_))),
                "burn_in_rows": est.info_["burn_in_rows"],
                "forgetting": est.info_["forgetting"],
            }
        elif kind == "ls":
            x = least_squares(problem)
            std = base_statistics(problem, x, kind="white")[0]  # works on a segmental SubProblem too
            half = np.maximum(10.0 * max(width, 1e-12) * std, 1e-9 * natural_scale(problem))
            lower, upper = x - half, x + half
        else:
            raise SpecError(f"box {box!r}, expected 'nominal', 'rls', 'ls', (lower, upper) or {{name: (lo, hi)}}")
        info["kind"] = kind
    elif isinstance(box, dict):
        lower, upper = nominal_box(problem, width, floor)
        for name, pair in box.items():
            try:
                lo, hi = (float(v) for v in pair)
            except (TypeError, ValueError):
                raise SpecError(f"box: {name} = {pair!r}, expected a (lower, upper) pair of numbers") from None
            if name not in names:
                raise SpecError(f"box: unknown base parameter {name!r} (base parameters: {', '.join(names)})")
            i = names.index(name)
            lower[i], upper[i] = float(lo), float(hi)
        info["kind"] = "nominal with overrides"
    else:
        try:
            lower, upper = (np.asarray(b, dtype=float).reshape(-1) for b in box)
        except (TypeError, ValueError):
            raise SpecError(f"box {box!r}: expected 'nominal', 'rls', 'ls', (lower, upper) arrays or a dict") from None
        if lower.shape != (nb,) or upper.shape != (nb,):
            raise SpecError(f"box: lower and upper with {lower.size} and {upper.size} values, expected {nb} each")
        info["kind"] = "given"
    lower, upper = np.asarray(lower, float).copy(), np.asarray(upper, float).copy()
    if np.any(~np.isfinite(lower)) or np.any(~np.isfinite(upper)) or np.any(lower > upper):
        raise SpecError("box: expected finite bounds with lower ≤ upper")
    # a degenerate dimension (an RLS range of zero width) gets a sliver, so the optimiser can move
    tiny = 1e-9 * np.maximum(natural_scale(problem), 1e-300)
    thin = upper - lower < tiny
    lower[thin] -= tiny[thin] / 2
    upper[thin] += tiny[thin] / 2
    info["lower"] = dict(zip(names, map(float, lower)))
    info["upper"] = dict(zip(names, map(float, upper)))
    return lower, upper, info


# ------------------------------------------------------------------------------------------- the box
@dataclass(frozen=True)
class SearchBox:
    """The box a metaheuristic searches (module text): ``kind`` "nominal", "rls", "ls", ``(lower, upper)``
    arrays or ``{name: (lo, hi)}`` overriding the nominal box (None: the estimator's own,
    :attr:`Metaheuristic.default_box`); ``width``: the nominal box's ± fraction of ``|x_nom|`` (the "ls"
    box: × 10 σ); ``floor``: the nominal box's least ± fraction of the natural magnitude; ``rls``: the
    settings of the :class:`~pinid.estimators.rls.RLS` run behind an "rls" box.  A wrong type: SpecError
    (one line); the kind and the bounds are checked against the problem when the box is built."""

    kind: Any = None
    width: float = 1.0
    floor: float = 0.5
    rls: Mapping | None = None

    def __post_init__(self) -> None:
        kind = self.kind
        if kind is not None and not isinstance(kind, (str, Mapping)) and not np.iterable(kind):
            raise SpecError(
                f"SearchBox kind: got {type(kind).__name__}, expected 'nominal', 'rls', 'ls', (lower, upper) or "
                "{name: (lo, hi)}"
            )
        for key in ("width", "floor"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(v) or v < 0:
                raise SpecError(f"SearchBox {key}={v!r}, expected a number ≥ 0")
        if self.rls is not None and not isinstance(self.rls, Mapping):
            raise SpecError(f"SearchBox rls: got {type(self.rls).__name__}, expected a table of RLS settings")

    @classmethod
    def of(cls, box) -> "SearchBox":
        """``box`` as a SearchBox: itself, or its ``kind`` (None: the defaults)."""
        return box if isinstance(box, SearchBox) else cls(kind=box)


#: The box's fields as flat settings of a metaheuristic (``make_estimator("pso", box_width=0.5)``,
#: ``--option pso.box_width=0.5``, ``pinid compare --box-width``): setting -> :class:`SearchBox` field.
BOX_SETTINGS = {"box_width": "width", "box_floor": "floor", "rls": "rls"}


# ------------------------------------------------------------------------------------------- estimators
class Metaheuristic(Estimator):
    """Base class: a population optimiser searching the base parameters in a box (module text).

    Subclasses set ``name``, ``description``, ``optimizer`` (a key of :data:`pinid.optimizers.OPTIMIZERS`)
    and ``default_box``.
    """

    calibrated_std = False  # a swarm's optimum has no sampling covariance to report
    cost = 10.0  # 2026-11-27, exo_leg 20 s twin: pso, woa 30 ms, ewoa 60 ms against 5 ms for ols

    optimizer: str = ""
    default_box = "nominal"
    deterministic = False
    history = "fitness"
    assumptions = (
        "as OLS; the optimum inside the search box (`box`) and reached in "
        "`iterations` (seeded: `pinid compare` runs several seeds)"
    )
    settings_summary = (
        '`population` (100), `iterations` (200), `fitness` ("sse"; "sae"), `box` (a `SearchBox`: kind "nominal"; '
        '"rls", "ls", bounds; width 1.0, floor 0.5, rls; flat: `box_width`, `box_floor`, `rls`), `seed` (0), `tol`, '
        "`options`, `x0` ([metaheuristics](metaheuristics.md))"
    )
    settings = {
        "population": Setting("int", low=2, help="particles per iteration"),
        "iterations": Setting("int", low=1, help="iterations"),
        "fitness": Setting("str", choices=tuple(FITNESS), help="sse: ½Σr² (seed 001); sae: Σ|r| (seed 000)"),
        "box": Setting(
            "any",
            optional=True,
            help="a SearchBox (kind, width, floor, rls) or its kind: 'nominal', 'rls', 'ls', (lower, upper) or "
            "{name: (lo, hi)}; its fields also as box_width, box_floor, rls",
        ),
        "seed": Setting("int", low=0, optional=True, help="seed of the random generator"),
        "tol": Setting("float", optional=True, help="stop when the best fitness falls below it"),
        "options": Setting("dict", optional=True, help="the optimiser's own settings"),
        "x0": Setting("any", optional=True, help="'nominal' or nb numbers: a particle of the first population"),
    }

    def __init__(
        self,
        population: int = 100,
        iterations: int = 200,
        fitness: str = "sse",
        box: SearchBox | str | tuple | dict | None = SearchBox(),
        seed: int = 0,
        tol: float | None = None,
        options: dict | None = None,
        x0=None,
    ) -> None:
        self.population = population
        self.iterations = iterations
        self.fitness = fitness
        self.box = box
        self.seed = seed
        self.tol = tol
        self.options = options
        self.x0 = x0

    @classmethod
    def create(cls, **settings) -> "Metaheuristic":
        """As :meth:`Estimator.create`, ``box`` made a :class:`SearchBox` with the flat settings of
        :data:`BOX_SETTINGS` (``box_width``, ``box_floor``, ``rls``) set on it."""
        flat = {k: settings.pop(k) for k in list(settings) if k in BOX_SETTINGS}
        if flat or "box" in settings:
            try:
                box = SearchBox.of(settings.get("box"))
                settings["box"] = replace(box, **{BOX_SETTINGS[k]: v for k, v in flat.items()})
            except SpecError as exc:
                raise SpecError(f"method '{cls.name}': {exc}") from None
        return super().create(**settings)

    def _box(self) -> tuple[Any, SearchBox]:
        """``(kind, box)``: the box's kind (the estimator's default when it names none) and the box."""
        box = SearchBox.of(self.box)
        return (self.default_box if box.kind is None else box.kind), box

    def lazy_imports(self) -> tuple[str, ...]:
        """What its optimiser imports on first use (``Optimizer.imports``)."""
        return OPTIMIZERS[self.optimizer].imports

    def shared_work(self) -> tuple[tuple[str, tuple], ...]:
        """The RLS run behind an ``"rls"`` box (kept in the problem's cache; every seed shares it)."""
        kind, box = self._box()
        return (
            RLS.create(**dict(box.rls or {})).shared_work() if isinstance(kind, str) and kind.lower() == "rls" else ()
        )

    def fit(self, problem: Problem) -> "Metaheuristic":
        """Search the box for the base parameters with the lowest fitness; sets ``base_``, ``history_``, ``path_``, ``box_``, ``info_``."""
        if self.fitness not in FITNESS:
            raise SpecError(f"{self.name}: fitness {self.fitness!r}, expected one of {', '.join(FITNESS)}")
        kind, b = self._box()
        lower, upper, box_info = search_box(problem, kind, width=b.width, floor=b.floor, rls=b.rls)
        extra = dict(self.options or {})
        clash = sorted({"population", "iterations"} & set(extra))
        if clash:
            raise SpecError(f"{self.name}: set {', '.join(clash)} as the estimator's own setting, not in options")
        opt = get_optimizer(self.optimizer, population=int(self.population), iterations=int(self.iterations), **extra)
        f = fitness_function(problem, self.fitness)
        path: list[np.ndarray] = []
        tol = self.tol

        def callback(it, x, fbest):
            path.append(x)
            return tol is not None and fbest < tol

        x0 = None
        if self.x0 is not None:
            if isinstance(self.x0, str):
                if self.x0 != "nominal":
                    raise SpecError(f"{self.name}: x0 {self.x0!r}, expected 'nominal' or {problem.nb} numbers")
                x0 = np.asarray(problem.nominal_base, float)
            else:
                x0 = np.asarray(self.x0, float)
        rng = np.random.default_rng(self.seed)
        t0 = time.perf_counter()
        res = opt.minimize(f, lower, upper, rng=rng, x0=x0, callback=callback)  # progress: pinid.progress
        seconds = time.perf_counter() - t0
        x = np.asarray(res.x, float)
        history = [float(h) for h in res.history]
        # the best particle after every iteration (seed 000 Figs. 8, 11)
        self.path_ = np.vstack(path) if path else x[None, :]
        if self.tol is not None and res.message.startswith("stopped by callback"):
            message = f"best fitness {res.fun:g} < tol {self.tol:g}"
        else:
            message = res.message
        x_ls = least_squares(problem)
        costs = training_costs(problem, x)
        ls_costs = training_costs(problem, x_ls)
        best = ls_costs["sse"] if self.fitness == "sse" else training_costs(problem, cached_lad(problem))["sae"]
        self.base_ = x
        self.box_ = (lower, upper)
        self.standard_ = None
        self.weights_ = None
        self.history_ = history
        self.status_ = "ok"
        at_bound = [
            n for n, v, lo, hi in zip(problem.names, x, lower, upper) if min(v - lo, hi - v) <= 1e-6 * (hi - lo)
        ]
        self.info_ = {
            "optimizer": self.optimizer,
            "optimizer_options": _plain(opt.options),
            "seed": self.seed,
            "fitness": self.fitness,
            "fitness_value": float(res.fun),
            "ls_fitness": float(ls_costs[self.fitness]),
            "min_fitness": float(best),
            "train_costs": costs,
            "ls_train_costs": ls_costs,
            "nfev": int(res.nfev),
            "iterations": int(res.nit),
            "message": message,
            "optimizer_seconds": seconds,
            "box": box_info,
            "at_bound": at_bound,
        }
        return self


def _plain(options) -> dict:
    import dataclasses

    d = dataclasses.asdict(options) if dataclasses.is_dataclass(options) else dict(options)
    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in d.items()}


class PSOEstimator(Metaheuristic):
    """Particle swarm (seed 000 Eqs. (7)-(8)) in the nominal box (module text)."""

    name = "pso"
    description = "particle swarm optimisation (seed 000 Eqs. (7)-(8)) in a box around the URDF's values"
    colour = "#9467bd"
    optimizer = "pso"


class RLSPSO(Metaheuristic):
    """Seed 000's RLS-PSO: particle swarm inside the box of a recursive least-squares run (§2.2, Fig. 4)."""

    name = "rls-pso"
    description = "particle swarm inside the range of a recursive least-squares run (seed 000 RLS-PSO)"
    colour = "#17becf"
    optimizer = "pso"
    default_box = "rls"


class WOAEstimator(Metaheuristic):
    """Whale optimisation (seed 001 Eqs. (14)-(17)) in the nominal box."""

    name = "woa"
    description = "whale optimisation (seed 001 Eqs. (14)-(17)) in a box around the URDF's values"
    colour = "#bcbd22"
    optimizer = "woa"


class EWOAEstimator(Metaheuristic):
    """Seed 001's enhanced whale optimisation (WOA + differential mutation, Eq. (18)) in the nominal box."""

    name = "ewoa"
    description = "enhanced whale optimisation (seed 001 Eqs. (14)-(18)) in a box around the URDF's values"
    colour = "#d62728"
    optimizer = "ewoa"


class DEEstimator(Metaheuristic):
    """scipy's differential evolution (vectorised) in the nominal box: an off-the-shelf reference."""

    name = "de"
    description = "scipy differential evolution in a box around the URDF's values (reference)"
    cost = 60.0  # 320 ms on the case of Metaheuristic.cost
    colour = "#e377c2"
    optimizer = "de"
