"""The interface every population-based optimiser follows.

An optimiser minimises a **batch** function ``f(X) -> (P,)`` of a population ``X`` of shape ``(P, d)``
inside a box ``lower <= x <= upper``: the whole swarm is evaluated in one call, so that the function can
use matrix products instead of a Python loop over particles.  Values that are NaN count as +inf (a
candidate the function cannot evaluate is simply the worst).

* ``__init__(options=None, **kw)`` only stores settings (a dataclass per method; keywords override it);
* ``minimize(fun_batch, lower, upper, *, rng, x0=None, callback=None, progress=None)`` returns an
  :class:`OptimizeResult`; the same ``rng`` seed gives the same result, bit for bit.

Adding an optimiser is one file (a subclass of :class:`Optimizer` with an ``Options`` dataclass and a
``_minimize`` method) plus one line in :data:`pinid.optimizers.OPTIMIZERS`.
"""

from __future__ import annotations

import dataclasses
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar
from collections.abc import Callable

import numpy as np

from pinid.checks import option_numbers
from pinid.errors import SolverError, SpecError
from pinid.result_protocol import ResultProtocol, panel

#: ``fun_batch(X) -> values``: X is ``(P, d)``, values ``(P,)``.
BatchFunction = Callable[[np.ndarray], np.ndarray]
#: ``callback(iteration, x_best, f_best) -> stop?``; returning True stops the run after that iteration.
Callback = Callable[[int, np.ndarray, float], "bool | None"]


@dataclass
class OptimizeResult(ResultProtocol):
    """What :meth:`Optimizer.minimize` returns.

    ``x``: best point found ``(d,)``; ``fun``: its value; ``history``: best value after the initial
    population (index 0) and after every iteration (index ``k``); ``nfev``: function values computed
    (candidates, not batch calls); ``nit``: iterations run; ``seconds``: wall time; ``message``: why it
    stopped.
    """

    x: np.ndarray
    fun: float
    history: np.ndarray
    nfev: int
    nit: int
    seconds: float
    message: str
    extra: dict = field(default_factory=dict)

    PLOTS = {"history": True}

    def to_dict(self) -> dict:
        """Plain-dict form (JSON-serialisable)."""
        return {
            "x": self.x.tolist(),
            "fun": float(self.fun),
            "history": [float(h) for h in self.history],
            "nfev": int(self.nfev),
            "nit": int(self.nit),
            "seconds": float(self.seconds),
            "message": self.message,
            **self.extra,
        }

    @classmethod
    def from_dict(cls, d: dict) -> "OptimizeResult":
        """Inverse of :meth:`to_dict` (keys it does not know go back to ``extra``)."""
        known = ("x", "fun", "history", "nfev", "nit", "seconds", "message")
        return cls(
            np.asarray(d["x"], dtype=float),
            float(d["fun"]),
            np.asarray(d["history"], dtype=float),
            int(d["nfev"]),
            int(d["nit"]),
            float(d["seconds"]),
            str(d["message"]),
            {k: v for k, v in d.items() if k not in known},
        )

    def text(self) -> str:
        """The best value, the work done and why it stopped, one line each."""
        return (
            f"best value {self.fun:.6g} at x = {np.array2string(self.x, precision=4)}\n"
            f"{self.nit} iterations, {self.nfev} function values, {self.seconds:.3g} s\n"
            f"stopped: {self.message}"
        )

    def _plot(self, kind: str, ax):
        """``"history"``: the best value after each iteration (log scale when every value is positive)."""
        fig, ax = panel(ax)
        h = np.asarray(self.history, dtype=float)
        ax.plot(np.arange(len(h)), h, "-", color="tab:blue")
        if len(h) and np.all(h[np.isfinite(h)] > 0):
            ax.set_yscale("log")
        ax.set_xlabel("iteration")
        ax.set_ylabel("best value")
        ax.set_title(f"convergence: best {self.fun:.4g} after {self.nit} iterations")
        fig.tight_layout()
        return fig


class _Counted:
    """Wrap a batch function: check shapes, count evaluations, NaN -> +inf."""

    def __init__(self, fun: BatchFunction, d: int) -> None:
        self.fun, self.d, self.nfev = fun, d, 0

    def __call__(self, X: np.ndarray) -> np.ndarray:
        X = np.ascontiguousarray(X, dtype=float)
        values = np.asarray(self.fun(X), dtype=float).reshape(-1)
        if values.shape != (len(X),):
            raise SolverError(
                f"objective returned shape {values.shape} for a population of {len(X)}, expected ({len(X)},)"
            )
        self.nfev += len(X)
        return np.where(np.isnan(values), np.inf, values)


class Optimizer(ABC):
    """Base class of the population-based optimisers (see the module documentation)."""

    #: Registry name (``"pso"``).
    name: ClassVar[str] = ""
    #: The options dataclass of this method.
    Options: ClassVar[type]
    #: Modules a run imports on first use (a study imports them once before it forks its workers).
    imports: ClassVar[tuple[str, ...]] = ()

    def __init__(self, options=None, **kw) -> None:
        if options is None:
            try:
                options = self.Options(**kw)
            except TypeError:
                known = [f.name for f in dataclasses.fields(self.Options)]
                bad = [k for k in kw if k not in known]
                raise SpecError(
                    f"{self.name}: unknown option(s) {', '.join(bad)} (options: {', '.join(known)})"
                ) from None
        elif kw:
            options = self._replace(options, kw)
        if not isinstance(options, self.Options):
            raise SpecError(f"{self.name}: options of type {type(options).__name__}, expected {self.Options.__name__}")
        self.options = options
        self._check_options()

    def _replace(self, options, kw: dict):
        known = [f.name for f in dataclasses.fields(self.Options)]
        bad = [k for k in kw if k not in known]
        if bad:
            raise SpecError(f"{self.name}: unknown option(s) {', '.join(bad)} (options: {', '.join(known)})")
        return dataclasses.replace(options, **kw)

    def _check_options(self) -> None:
        """Raise SpecError for settings that cannot work (override to add checks)."""
        o = self.options
        option_numbers(o, self.name)
        for key in ("population", "iterations"):
            value = getattr(o, key, None)
            if value is not None and (int(value) != value or value < 1):
                raise SpecError(f"{self.name}: {key} {value!r}, expected a positive integer")

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.options})"

    def minimize(
        self,
        fun_batch: BatchFunction,
        lower,
        upper,
        *,
        rng: np.random.Generator | int | None = None,
        x0=None,
        callback: Callback | None = None,
        progress: bool | None = None,
    ) -> OptimizeResult:
        """Minimise ``fun_batch`` over the box ``[lower, upper]``.

        ``rng``: a seeded Generator or an integer seed (None: seed 0, so that runs repeat exactly).
        ``x0``: one point ``(d,)`` or several ``(k, d)`` put into the initial population (clipped to the box).
        ``callback(iteration, x_best, f_best)``: called after every iteration; True stops the run.
        ``progress``: show a progress bar (None: on a terminal only, see :mod:`pinid.progress`).
        """
        lower = np.asarray(lower, dtype=float).reshape(-1)
        upper = np.asarray(upper, dtype=float).reshape(-1)
        if lower.shape != upper.shape or lower.size == 0:
            raise SpecError(f"{self.name}: bounds of shapes {lower.shape} and {upper.shape}, expected two (d,) arrays")
        if not (np.all(np.isfinite(lower)) and np.all(np.isfinite(upper))):
            raise SpecError(f"{self.name}: bounds must be finite")
        if np.any(lower > upper):
            i = int(np.argmax(lower > upper))
            raise SpecError(f"{self.name}: lower bound {lower[i]:g} > upper bound {upper[i]:g} in dimension {i}")
        if not isinstance(rng, np.random.Generator):
            rng = np.random.default_rng(0 if rng is None else rng)
        if x0 is not None:
            x0 = np.atleast_2d(np.asarray(x0, dtype=float))
            if x0.shape[1] != lower.size:
                raise SpecError(f"{self.name}: x0 has {x0.shape[1]} values, expected {lower.size}")
            x0 = np.clip(x0, lower, upper)
        f = _Counted(fun_batch, lower.size)
        start = time.perf_counter()
        x, fun, history, nit, message, extra = self._minimize(f, lower, upper, rng, x0, callback, progress)
        return OptimizeResult(
            np.asarray(x, float).copy(),
            float(fun),
            np.asarray(history, float),
            f.nfev,
            nit,
            time.perf_counter() - start,
            message,
            extra,
        )

    @abstractmethod
    def _minimize(self, f, lower, upper, rng, x0, callback, progress):
        """Run the method; return ``(x, fun, history, nit, message, extra)``."""


def initial_population(
    rng: np.random.Generator, n: int, lower: np.ndarray, upper: np.ndarray, x0: np.ndarray | None
) -> np.ndarray:
    """``n`` points uniform in the box (seed 000 Eq. (7)), the first rows replaced by ``x0`` if given."""
    X = lower + rng.random((n, lower.size)) * (upper - lower)
    if x0 is not None:
        k = min(len(x0), n)
        X[:k] = x0[:k]
    return X


def stop_requested(callback: Callback | None, it: int, x: np.ndarray, fun: float) -> bool:
    """Call the user's callback; True if it asks to stop."""
    return bool(callback is not None and callback(it, x.copy(), float(fun)))
