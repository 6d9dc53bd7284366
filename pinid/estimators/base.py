"""The estimator contract and the least-squares helpers estimators share.

An estimator follows the scikit-learn contract:

* ``__init__`` only stores its settings (keyword arguments, kept as attributes of the same name);
* ``fit(problem)`` takes a :class:`~pinid.problem.problem.Problem` (an
  :class:`~pinid.problem.problem.IdentificationProblem` or a segmental stage) and returns ``self``;
* fitted values end in ``_``:

  ``base_``       (nb,) base parameters, in the order of ``problem.base.names`` (required)
  ``standard_``   (p,) full standard parameters, or None when the estimator does not produce them
  ``weights_``    (rows,) row weights the fit used (None: ``problem.weights``); the standard deviations
                  and the condition number are computed with them
  ``history_``    list of floats (the cost per iteration), or None
  ``status_``     short text: ``"optimal"``, ``"ok"`` … (what the solver said)
  ``info_``       dict of anything else worth reporting (JSON-serialisable)

What the rest of pinid needs to know about an estimator it reads from class attributes: ``name``,
``description``, ``deterministic`` (run once in a comparison, not once per seed), ``history`` (what
``history_`` holds, for the convergence plots), ``colour`` (in every figure), ``settings`` (a
:class:`Setting` per ``__init__`` argument: types, range, choices — :meth:`Estimator.create` checks
them, so a bad setting is a :class:`~pinid.errors.SpecError` before any data is read).

Adding an estimator is one file in ``pinid/estimators/`` with a subclass of :class:`Estimator` and one
line in the registry of ``pinid/estimators/__init__.py`` (docs/architecture.md has a worked example).
"""

from __future__ import annotations

import inspect
import numbers
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from pinid.errors import SpecError
from pinid.problem.problem import Problem


@dataclass(frozen=True)
class Setting:
    """One setting of an estimator: what values it takes.  ``kind``: "int", "float", "bool", "str",
    "dict" or "any"; ``low``/``high``: inclusive bounds (``low_open``: strictly above ``low``);
    ``choices``: the allowed values; ``optional``: None allowed; ``help``: one line with units."""

    kind: str = "any"
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    choices: tuple | None = None
    optional: bool = False
    help: str = ""

    def check(self, method: str, key: str, value: Any) -> Any:
        """``value`` checked (an integral float becomes an int for "int"); SpecError naming the setting."""
        where = f"method '{method}': setting {key}={value!r}"
        if value is None:
            if self.optional:
                return None
            raise SpecError(f"{where}, expected {self.expected()}")
        kinds = {"int": numbers.Integral, "float": numbers.Real, "bool": (bool, np.bool_), "str": str, "dict": dict}
        if (
            self.kind == "int"
            and isinstance(value, numbers.Real)
            and not isinstance(value, bool)
            and float(value).is_integer()
        ):
            value = int(value)
        if self.kind in kinds and (
            not isinstance(value, kinds[self.kind]) or (self.kind in ("int", "float") and isinstance(value, bool))
        ):
            raise SpecError(f"{where}, expected {self.expected()}")
        if self.choices is not None and value not in self.choices:
            raise SpecError(f"{where}, expected {self.expected()}")
        if self.kind in ("int", "float"):
            v = float(value)
            if (
                not np.isfinite(v)
                or (self.low is not None and (v < self.low or (self.low_open and v == self.low)))
                or (self.high is not None and v > self.high)
            ):
                raise SpecError(f"{where}, expected {self.expected()}")
        return value

    def expected(self) -> str:
        """What the setting takes, in words (for errors and the CLI's help)."""
        if self.choices is not None:
            text = "one of " + ", ".join(map(str, self.choices))
        else:
            text = {
                "int": "an integer",
                "float": "a number",
                "bool": "true or false",
                "str": "a string",
                "dict": "a table of settings",
                "any": "a value",
            }[self.kind]
            if self.low is not None and self.high is not None:
                text += f" in {'(' if self.low_open else '['}{self.low:g}, {self.high:g}]"
            elif self.low is not None:
                text += f" {'>' if self.low_open else '≥'} {self.low:g}"
            elif self.high is not None:
                text += f" ≤ {self.high:g}"
        return text + (" or none" if self.optional else "")


class Estimator:
    """Base class: settings in ``__init__``, ``fit(problem) -> self``, fitted values ending in ``_``."""

    #: Registry name (``"ols"``); set by subclasses.
    name: str = "estimator"
    #: One line for tables and the report.
    description: str = ""
    #: The row of the methods' table of docs/identification.md (generated: ``python -m pinid.docgen
    #: methods-table --write``), Markdown: what it does (default :attr:`description`), what it assumes of
    #: the data, and its settings with their defaults (default: the names and defaults of ``__init__``).
    summary: ClassVar[str] = ""
    assumptions: ClassVar[str] = ""
    settings_summary: ClassVar[str] = ""
    #: True when ``standard_`` is physically consistent by construction (constrained: a value on a bound
    #: gets no σ, :func:`pinid.identification.result.make_result`).
    consistent_by_construction: bool = False
    #: True when the estimator fits the full standard parameters and runs the stages of a staged
    #: (segmental) fit itself with ``fit_stage`` (see :class:`~pinid.estimators.sdp.SDP`).
    fits_standard: ClassVar[bool] = False
    #: True when the least-squares sandwich covariance (:func:`pinid.problem.statistics.base_statistics`)
    #: describes the estimate's spread; False (metaheuristics): the result prints no σ.
    calibrated_std: ClassVar[bool] = True
    #: True when the result does not depend on a random seed (a comparison runs it once).
    deterministic: ClassVar[bool] = True
    #: True when, on noise-free data, a deterministic estimator returns the truth to round-off; False when
    #: something else limits it (DIDIM's simulation of the model between samples).
    exact: ClassVar[bool] = True
    #: True when a fit simulates the robot (iv, didim: tens of seconds on a long recording): the defaults
    #: that run every method (``pinid compare``, ``pinid demo``) leave it out; ``--methods`` or "all" names it.
    simulates: ClassVar[bool] = False
    #: A fit's time relative to a least-squares fit's (1), roughly: parallel runs start the costliest jobs
    #: first, so that no long job is left to end alone on one worker (:func:`~pinid.identification.runner.run_jobs`).
    cost: ClassVar[float] = 1.0
    #: False when the defaults that run every method (``pinid compare``, ``pinid demo``) leave it out though it
    #: does not simulate (``essential``: a variant of ``ols`` that would add a fit to every default run; ``logdet``: its weight
    #: cross-validated, some 50 conic solves, seconds on a 7-joint arm).
    in_defaults: ClassVar[bool] = True
    #: What ``history_`` holds: "none"; "passes" (the cost after each pass); "rows" (an error along the
    #: rows); "fitness" (the best fitness per iteration: drawn as a convergence curve).
    history: ClassVar[str] = "none"
    #: Matplotlib colour of this method in every figure (:func:`pinid.report.colors.method_color`; None: a
    #: fallback colour from the method name).  Distinct from every registered method's and from grey and black
    #: (the measurements), tests/report/test_report_colors.py.
    colour: ClassVar[str | None] = None
    #: The settings ``__init__`` takes, each with its accepted values (checked by :meth:`create`).
    settings: ClassVar[dict[str, Setting]] = {}

    base_: np.ndarray
    standard_: np.ndarray | None = None
    weights_: np.ndarray | None = None
    history_: list | None = None
    status_: str = "ok"
    info_: dict

    @classmethod
    def create(cls, **settings) -> "Estimator":
        """An instance with ``settings`` checked against :attr:`settings` (SpecError for an unknown or bad one)."""
        known = [k for k in inspect.signature(cls.__init__).parameters if k != "self"]
        unknown = sorted(k for k in settings if k not in known)
        if unknown:
            raise SpecError(
                f"method '{cls.name}': bad settings {sorted(settings)} (unknown {', '.join(unknown)}; "
                f"expected some of {', '.join(known) or 'none'})"
            )
        checked = {k: (cls.settings[k].check(cls.name, k, v) if k in cls.settings else v) for k, v in settings.items()}
        return cls(**checked)

    def fit(self, problem: Problem) -> "Estimator":  # pragma: no cover - abstract
        """Estimate the base parameters of ``problem`` (a :class:`~pinid.problem.problem.Problem`); set the fitted attributes (``base_`` …) and return ``self``."""
        raise NotImplementedError

    def shared_work(self) -> tuple[tuple[str, tuple], ...]:
        """The fits this estimator's ``fit`` makes and keeps in the problem's ``cache``, as ``(method,
        settings)`` pairs (``settings``: sorted ``(name, value)`` pairs): a study on parallel processes, which
        do not share a cache, runs each once before its jobs (:func:`pinid.identification.runner.run_jobs`).
        Default: none."""
        return ()

    def lazy_imports(self) -> tuple[str, ...]:
        """Modules ``fit`` imports on first use: a study on local processes imports them before it forks its
        workers, so that each worker does not import them again (:func:`pinid.identification.runner.run_jobs`)."""
        return ()

    def get_params(self) -> dict:
        """The settings given to ``__init__`` (scikit-learn style)."""
        sig = inspect.signature(type(self).__init__)
        return {k: getattr(self, k) for k in sig.parameters if k != "self" and hasattr(self, k)}

    def predict(self, W: np.ndarray) -> np.ndarray:
        """Torque ``W @ base_`` for a stacked base regressor ``W``."""
        return np.asarray(W) @ self.base_

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"


def joint_weights(problem, residual: np.ndarray, floor: float = 1e-12) -> tuple[np.ndarray, np.ndarray]:
    """Row weights 1/σ_j² from the residual variance σ_j² of each joint's rows; returns ``(weights, σ)``.

    σ_j² = Σ_{rows of j} r² / (n_j − nb·n_j/rows) (the degrees of freedom shared out by row count).
    A joint with (numerically) no residual gets σ_j floored at ``floor``·RMS(τ_j) so weights stay finite.
    """
    nv, nb, rows = problem.nv, problem.nb, problem.rows
    sigma = np.zeros(nv)
    for j in range(nv):
        sel = problem.joint == j
        n_j = int(sel.sum())
        if n_j == 0:
            sigma[j] = 1.0
            continue
        dof = max(n_j - nb * n_j / rows, 1.0)
        s2 = float(residual[sel] @ residual[sel]) / dof
        tau_rms = float(np.sqrt(np.mean(problem.tau[sel] ** 2))) if n_j else 1.0
        sigma[j] = max(np.sqrt(s2), floor * max(tau_rms, 1e-300))
    return (1.0 / sigma**2)[problem.joint], sigma


__all__ = ["Estimator", "Setting", "joint_weights"]
