"""Excitation design: Fourier trajectories that make the base regressor well conditioned within limits.

The trajectory of every joint is a finite Fourier series (seed 001 Eq. (19), :class:`FourierTrajectory`)::

    q_j(t) = q0_j + Σ_{k=1..N} a_jk sin(k ω t) + b_jk cos(k ω t)

and :func:`design_excitation` minimises a criterion of the **base regressor** ``W_b``
(:mod:`pinid.excitation.evaluation`: ``cond``, the default, or ``logdet``) stacked over ``samples``
equally spaced instants of one period, subject to the limits of every joint — position, velocity,
acceleration, optionally torque — at every instant of the period, not only at the samples.  The limits
and settings are an :class:`~pinid.excitation.spec.ExcitationSpec` (:mod:`pinid.excitation.spec`); the
variables, constraints and gradient are a :class:`~pinid.excitation.problem.DesignProblem`
(:mod:`pinid.excitation.problem`).  This module holds the drivers that search it.

Optimisers
----------
``slsqp`` (default) is a gradient-based multistart made for this problem.  With the offsets fixed (or
free), q, dq and ddq are *linear* in the design variables, so the kinematic limits on a grid of the
period (twice as fine as the samples) are linear inequality constraints, handed to scipy's SLSQP exactly
— on robots of more than ``SMALL_ROBOT`` joints, only at each signal's local maxima over the period
(:mod:`pinid.excitation.peaks`: the same limits with 6·nv·harmonics rows, SLSQP's subproblem being most
of a design's time).
The gradient of log cond(W_b) comes from the singular vectors of W_b and the derivatives of each
sample's regressor row with respect to that sample's state (:meth:`DesignProblem.objective_and_gradient`).
The landscape has many local minima, so the search has two phases (:class:`MultistartOptions`): many
short local searches on a cheaper problem (50 samples per period), from the best of several random
feasible points each, then the best few results polished on the full problem.

The metaheuristics of :mod:`pinid.optimizers` (``pso``, ``woa``, ``ewoa``, ``de``) search the same
variables inside a box; the limits hold **by construction**: each candidate's coefficients are scaled,
per joint, by the largest factor ≤ 1 that brings its position, velocity and acceleration inside the
limits on the grid (the offset stays).  The reported best is therefore feasible.  Torque limits, which
scaling cannot guarantee, are a penalty for the metaheuristics and nonlinear constraints for SLSQP.

Whatever the optimiser, the final trajectory is checked on a dense grid (``DENSE_SAMPLES`` per period,
extremes refined by Newton steps on the analytic derivatives) and, if it overshoots a limit between the
design samples, scaled back inside (a change of the order of 1e-4 of the amplitudes); the condition
number reported is then recomputed with :func:`~pinid.excitation.evaluation.condition_number` on the
``samples`` grid.
"""

from __future__ import annotations

import sys
import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from pinid.blas import single_threaded_blas
from pinid.checks import option_numbers
from pinid.errors import SpecError
from pinid.model.floating import FloatingRobotModel
from pinid.model.robot import RobotModel, as_robot
from pinid.excitation.trajectory import FourierTrajectory
from pinid.model.terms import TermSelection
from pinid.result_protocol import ResultProtocol
from pinid.optimizers import OPTIMIZERS, get_optimizer
from pinid.progress import progress as progress_bar
from pinid.excitation.spec import ExcitationSpec, spec_for
from pinid.excitation.evaluation import (
    DENSE_SAMPLES,
    evaluate_trajectory,
    is_feasible,
    sample_times,
    trajectory_extremes,
)
from pinid.excitation.problem import DesignProblem
from pinid.excitation.peaks import PeakConstraints
from pinid.excitation.workers import SearchWorkers, pool_size

#: robots with up to this many joints get the full default multistart (128 starts, 2 polished)
SMALL_ROBOT = 4

#: starts per batch of phase 1: a start is stopped early against the best of the batches before it, so
#: that the design does not depend on the number of worker processes
BATCH = 8

#: for the expected time (:class:`_Estimate`), per way of seeing the limits (``MultistartOptions.limits``):
#: the share of phase 1's starts' time that is spent when starts are stopped early, and the time of one
#: polish in search starts, the first start's time the unit.  Measured 2026-11-27 (docs/benchmarks.md, issue
#: 35): on the grid (exo_leg, 88 of 128 starts stopped early) 0.15 and 3.8; at the peaks (UR5, Panda: no
#: start stopped early) 0.7–1.5 and 1.9–2.3.  Earlier (the grid before the peaks merge): 0.5 and 8.
ESTIMATE_COSTS: dict[str, tuple[float, float]] = {"grid": (0.15, 4.0), "peaks": (1.0, 2.5)}

#: a design expected to take longer than this [s] says so on stderr first
LONG = 5.0


# ====================================================================================== results
@dataclass
class MultistartOptions:
    """Settings of the default ``slsqp`` design: a two-phase SLSQP multistart.

    Phase 1 (search): ``starts`` local searches on a cheaper problem — ``search_samples`` samples per
    period (None: ``max(50, 12·harmonics)``, at most ``samples``) and limits on a grid of twice that —
    each from the best of ``screen`` random feasible candidates, with loose tolerances (``maxiter``,
    ``ftol``).  Phase 2 (polish): the ``polish`` best distinct results are refined on the full problem
    (``samples`` per period, limits on a grid of ``2·samples``) with ``polish_maxiter`` and ``polish_ftol``.
    ``time_limit`` [s]: no new phase-1 start after it (None: no limit).

    Early stop: after ``stop_after`` iterations, a search start whose value (scaled into the limits) is
    more than ``stop_ratio`` times the best of the batches of :data:`BATCH` starts before it is given up
    (0: never).  ``workers``: processes the starts and polishes run in (None: one per core; the result
    does not depend on it).

    ``polish_grid``: points per period of the polish's constraint grid (None: ``2·samples`` up to
    ``SMALL_ROBOT`` joints, ``samples`` above — SLSQP's subproblem grows faster than its 6·nv·grid rows;
    the design is scaled inside the limits at every instant afterwards whatever the grid).

    ``limits``: how SLSQP sees the kinematic limits — ``"grid"``, one linear row per point of the constraint
    grid, or ``"peaks"``, one row per local maximum of each joint's q, dq, ddq over the period
    (:class:`~pinid.excitation.peaks.PeakConstraints`: 6·nv·harmonics rows, 2–3× less CPU on a 6-DOF arm).
    None: ``"grid"`` up to ``SMALL_ROBOT`` joints (the designs of small robots stay as they were), ``"peaks"``
    above.  The two follow different paths to different local minima (docs/benchmarks.md, "Issue 35,
    fourth step").

    ``starts``, ``polish`` and ``stop_ratio`` left at None depend on the robot's size (:meth:`resolved`):
    128, 2 and 1.25 up to ``SMALL_ROBOT`` (4) joints, 12, 2 and 0 above — on a 6- or 7-DOF arm one search
    start costs 0.3–1.5 s and one polish 3–10 s here (the two polishes run on two cores at once), and the
    search's ranking of a few starts says little about the polished result, so every start runs to its end.
    """

    starts: int | None = None
    screen: int = 8
    polish: int | None = None
    search_samples: int | None = None
    maxiter: int = 100
    ftol: float = 1e-5
    polish_maxiter: int = 300
    polish_ftol: float = 1e-9
    time_limit: float | None = None
    stop_after: int = 3
    stop_ratio: float | None = None
    workers: int | None = None
    polish_grid: int | None = None
    limits: str | None = None

    def resolved(self, nv: int) -> "MultistartOptions":
        """These options with ``starts``, ``polish``, ``stop_ratio`` and ``limits`` filled in for a robot of
        ``nv`` joints."""
        small = nv <= SMALL_ROBOT
        return replace(
            self,
            starts=(128 if small else 12) if self.starts is None else self.starts,
            polish=2 if self.polish is None else self.polish,
            stop_ratio=(1.25 if small else 0.0) if self.stop_ratio is None else self.stop_ratio,
            limits=("grid" if small else "peaks") if self.limits is None else self.limits,
        )


#: Names accepted by :func:`design_excitation` (``slsqp`` plus the population-based optimisers).
def design_optimizers() -> list[str]:
    return ["slsqp", *OPTIMIZERS]


@dataclass
class ExcitationResult(ResultProtocol):
    """A designed excitation: the trajectory and what the design reached."""

    trajectory: FourierTrajectory
    spec: ExcitationSpec
    condition_number: float
    log_det: float
    extremes: dict
    usage: dict
    feasible: bool
    optimizer: str
    optimizer_options: dict
    seed: int | None
    seconds: float
    history: np.ndarray
    nfev: int
    tau_abs_max: np.ndarray | None = None
    details: dict = field(default_factory=dict)

    @property
    def criterion(self) -> str:
        """The criterion minimised: ``cond`` (condition number) or ``logdet`` (D-optimal)."""
        return self.spec.criterion

    PLOTS = {"trajectory": False}
    FILE_KIND = "excitation design"

    def _plot(self, kind: str, ax):
        """``"trajectory"``: q [rad], dq [rad/s], ddq [rad/s²] over one period within the spec's limits, as
        ``pinid excite --plot`` draws them (:func:`pinid.report.plot_excitation.plot_excitation`)."""
        from pinid.report.plot_excitation import plot_excitation  # loads matplotlib: on use only

        cond = f"condition number {self.condition_number:.4g}"
        return plot_excitation(
            self.trajectory, self.spec, title=f"{len(self.trajectory.joints)}-joint excitation, {cond}"
        )

    def text(self) -> str:
        """What ``pinid excite`` prints (:func:`pinid.excitation.outputs.design_text`)."""
        from pinid.excitation.outputs import design_text

        return design_text(self, self.spec)

    def to_dict(self) -> dict:
        """The JSON form: the trajectory (FourierTrajectory's keys, radians) plus the design report."""
        report = {
            "condition_number": float(self.condition_number),
            "criterion": self.spec.criterion,
            "log_det": float(self.log_det),
            "feasible": bool(self.feasible),
            "rest_start": bool(self.spec.rest_start),
            "samples": int(self.spec.samples),
            "terms": self.spec.terms.names,
            "limits": self.spec.limits_dict(),
            "margin": float(self.spec.margin),
            "extremes": self.extremes,
            "usage": self.usage,
            "optimizer": self.optimizer,
            "optimizer_options": self.optimizer_options,
            "seed": self.seed,
            "seconds": round(float(self.seconds), 3),
            "nfev": int(self.nfev),
            "history": [float(h) for h in self.history],
            "spec": self.spec.source,
            "urdf": self.details.get("urdf"),
            "robot": self.details.get("robot"),
        }
        report.update({k: v for k, v in self.details.items() if k not in report})
        traj = FourierTrajectory(
            self.trajectory.joints,
            self.trajectory.base_frequency,
            self.trajectory.q0,
            self.trajectory.a,
            self.trajectory.b,
            meta=report,
        )
        return traj.to_dict()

    @classmethod
    def from_dict(cls, d: dict) -> "ExcitationResult":
        """Inverse of :meth:`to_dict`: the trajectory and the spec's limits and settings from the report
        (the file :meth:`save` writes is also a :class:`FourierTrajectory`)."""
        traj = FourierTrajectory.from_dict(d, source="excitation design")
        meta = dict(traj.meta)
        limits = meta["limits"]
        joints = traj.joints

        def lim(key: str, missing: float) -> np.ndarray:
            return np.array([missing if limits[j][key] is None else float(limits[j][key]) for j in joints])

        spec = ExcitationSpec(
            joints,
            lim("q_min", -np.inf),
            lim("q_max", np.inf),
            lim("dq_max", np.inf),
            lim("ddq_max", np.inf),
            traj.q0,
            lim("tau_max", np.inf),
            harmonics=traj.harmonics,
            base_frequency=traj.base_frequency,
            samples=int(meta["samples"]),
            rest_start=bool(meta["rest_start"]),
            margin=float(meta["margin"]),
            criterion=str(meta["criterion"]),
            terms=TermSelection.from_names(meta["terms"]),
            source=str(meta["spec"]),
        )
        report = {"condition_number", "criterion", "log_det", "feasible", "rest_start", "samples", "terms", "limits"}
        report |= {"margin", "extremes", "usage", "optimizer", "optimizer_options", "seed", "seconds", "nfev"}
        report |= {"history", "spec"}  # :meth:`to_dict`'s own keys; the others (urdf, robot, …) are details
        details = {k: v for k, v in meta.items() if k not in report}
        trajectory = FourierTrajectory(joints, traj.base_frequency, traj.q0, traj.a, traj.b)
        return cls(
            trajectory,
            spec,
            float(meta["condition_number"]),
            float(meta["log_det"]),
            meta["extremes"],
            meta["usage"],
            bool(meta["feasible"]),
            str(meta["optimizer"]),
            dict(meta["optimizer_options"]),
            meta["seed"],
            float(meta["seconds"]),
            np.asarray(meta["history"], dtype=float),
            int(meta["nfev"]),
            None,
            details,
        )


def _final_repair(problem: DesignProblem, x: np.ndarray) -> tuple[np.ndarray, FourierTrajectory]:
    """Scale x into the limits on the dense grid (exact extremes); returns the new x and trajectory."""
    tr = problem.trajectory(x)
    if is_feasible(trajectory_extremes(tr), problem.spec):
        return x, tr
    dense = sample_times(problem.spec.period, DENSE_SAMPLES)
    for safety in (1e-9, 1e-7, 1e-5, 1e-3):
        x2 = problem.scale_into_limits(x[None, :], dense, safety=safety)[0]
        tr = problem.trajectory(x2)
        if is_feasible(trajectory_extremes(tr), problem.spec):
            return x2, tr
    return x2, tr


# ====================================================================================== design
def design_excitation(
    model: RobotModel,
    spec: ExcitationSpec | None = None,
    *,
    optimizer: str = "slsqp",
    options: dict | None = None,
    seed: int = 0,
    progress: bool | None = None,
    x0: np.ndarray | None = None,
) -> ExcitationResult:
    """Design an excitation trajectory for ``model`` under ``spec`` (default: :func:`spec_for` the model).

    ``optimizer``: ``"slsqp"`` (gradient-based multistart, :class:`MultistartOptions`) or a name of
    :data:`pinid.optimizers.OPTIMIZERS` (``pso``, ``woa``, ``ewoa``, ``de``) with their options;
    ``options``: settings of that optimiser (dict); ``seed``: the random seed (same seed → same result);
    ``x0``: a starting point (design variables, see :class:`DesignProblem`).

    Raises SpecError when the limits cannot be met; returns an :class:`ExcitationResult` whose trajectory
    is inside the limits on a dense grid (``feasible`` is False only if torque limits could not be met).
    BLAS runs single-threaded meanwhile: the work is many small matrix operations, which OpenBLAS's
    threads slow down (up to 4× on 2 cores) and make irreproducible.  A floating robot's trajectory is designed
    on its joints with the base held still (``model.fixed_base``), as ``pinid excite --base floating`` does.
    """
    model = as_robot(model)
    if isinstance(model, FloatingRobotModel):
        model = model.fixed_base
    spec = spec or spec_for(model)
    with single_threaded_blas():
        return _design(model, spec, optimizer, options, seed, progress, x0)


def _design(model, spec, optimizer, options, seed, progress, x0) -> ExcitationResult:
    start = time.perf_counter()
    problem = DesignProblem(model, spec)
    rng = np.random.default_rng(seed)
    options = dict(options or {})
    name = optimizer.lower()
    if name == "slsqp":
        known = list(MultistartOptions.__dataclass_fields__)
        unknown = [k for k in options if k not in known]
        if unknown:
            raise SpecError(f"slsqp: unknown option(s) {', '.join(unknown)} (options: {', '.join(known)})")
        opts = MultistartOptions(**options)
        option_numbers(opts, "slsqp")
        opts = opts.resolved(model.nv)
        if opts.polish_grid is None:
            opts = replace(opts, polish_grid=spec.samples * (2 if model.nv <= SMALL_ROBOT else 1))
        x, history, extra = _multistart(problem, opts, rng, progress, x0)
        used_options = asdict(opts)
    elif name in OPTIMIZERS:
        opt = get_optimizer(name, **options)
        x, history, extra = _metaheuristic(problem, opt, rng, progress, x0)
        used_options = asdict(opt.options)
    else:
        raise SpecError(f"unknown optimizer {optimizer!r}, expected one of {', '.join(design_optimizers())}")
    x, traj = _final_repair(problem, x)
    ev = evaluate_trajectory(model, traj, spec, base=problem.base)
    seconds = time.perf_counter() - start
    nfev = problem.nfev + int(extra.pop("search_nfev", 0))
    samples = problem.regressor_samples + int(extra.pop("search_regressor_samples", 0))
    details = {
        "robot": model.name,
        "urdf": str(model.urdf_path) if model.urdf_path else None,
        "regressor_samples": samples,
        **extra,
    }
    return ExcitationResult(
        traj,
        spec,
        ev["condition_number"],
        ev["log_det"],
        ev["extremes"],
        ev["usage"],
        ev["feasible"],
        name,
        used_options,
        seed,
        seconds,
        np.asarray(history, float),
        nfev,
        ev["tau_abs_max"],
        details,
    )


class _Stopped(Exception):
    """A local search stopped early (it could not beat the best found): its iterate ``x``."""

    def __init__(self, x: np.ndarray) -> None:
        self.x = x


def _local_search(
    problem: DesignProblem,
    x: np.ndarray,
    maxiter: int,
    ftol: float,
    stop: tuple[int, float] | None = None,
    peaks: bool = False,
) -> tuple[np.ndarray, float, int]:
    """SLSQP from ``x`` with the kinematic limits as linear constraints on the check grid — or, with ``peaks``,
    at each signal's local maxima (:class:`PeakConstraints`) — and torque limits as nonlinear ones;
    returns the result scaled into the limits on the check grid, its criterion value and the SLSQP
    iterations (−1: stopped early).  Gradients: :meth:`DesignProblem.objective_and_gradient`.

    ``stop = (k, limit)``: after k iterations, give up if the criterion value of the iterate (scaled into
    the limits) is above ``limit`` — a start that far behind the best found rarely ends better."""
    from scipy.optimize import minimize

    A, b = problem.linear_constraints()
    torque = problem.spec.has_torque_limits
    h = 1e-7

    # the line search asks for values only: the gradient (four times the cost) only where SLSQP needs it,
    # reusing the regressor and SVD of the value at the same point
    def fun(x):
        f = problem.objective(x)[0]
        return f if np.isfinite(f) else 1e10

    grads: dict = {}

    def gradient(x):
        key = x.tobytes()
        if key not in grads:
            grads.clear()
            grads[key] = problem.objective_and_gradient(x, h, torque=torque)
        return grads[key]

    def jac(x):
        g = gradient(x)[1]
        return np.where(np.isfinite(g), g, 0.0)

    if peaks:
        at_peaks = PeakConstraints(problem, A, b)
        constraints = [{"type": "ineq", "fun": at_peaks.fun, "jac": at_peaks.jac}]
    else:
        minus_A = -A  # once: SLSQP asks for the constraints' Jacobian at every iterate
        constraints = [{"type": "ineq", "fun": lambda x: b - A @ x, "jac": lambda x: minus_A}]
    if torque:
        limit = problem.spec.torque
        finite = np.isfinite(np.tile(limit, len(problem.times)))
        lim = np.tile(limit, len(problem.times))[finite]

        def tau_con(x):
            tau = problem.objective(x, torque=True)[1].reshape(-1)[finite]
            return np.concatenate([lim - tau, lim + tau])

        def tau_jac(x):
            J = gradient(x)[3][finite]
            return np.vstack([-J, J])

        constraints.append({"type": "ineq", "fun": tau_con, "jac": tau_jac})
    iterations = [0]

    def callback(xk):
        iterations[0] += 1
        if iterations[0] == stop[0] and problem.evaluate(problem.scale_into_limits(xk[None, :]))[0] > stop[1]:
            raise _Stopped(np.array(xk, dtype=float))

    try:
        res = minimize(
            fun,
            x,
            jac=jac,
            method="SLSQP",
            constraints=constraints,
            options={"maxiter": int(maxiter), "ftol": float(ftol)},
            callback=callback if stop is not None and np.isfinite(stop[1]) else None,
        )
    except _Stopped as stopped:
        X, values = _scaled_values(problem, stopped.x[None, :], torque)
        return X[0], float(values[0]), -1
    # SLSQP leaves tolerance-level violations: scale into the limits; and when it stops on a failed line
    # search its last iterate can be worse than where it started: keep the better of the two
    X, values = _scaled_values(problem, np.vstack([res.x, x]), torque)
    k = 0 if values[0] <= values[1] else 1
    return X[k], float(values[k]), int(res.nit)


def _scaled_values(problem: DesignProblem, X: np.ndarray, torque: bool) -> tuple[np.ndarray, np.ndarray]:
    """The candidates ``X`` scaled into the limits on the check grid and their criterion values (inf where
    a torque limit is exceeded)."""
    X = problem.scale_into_limits(X)
    if not torque:
        return X, problem.evaluate(X)
    values, tau = problem.evaluate(X, torque=True)
    return X, np.where(problem.torque_violation(tau) > 1e-6, np.inf, values)


def _multistart(
    problem: DesignProblem,
    opts: MultistartOptions,
    rng: np.random.Generator,
    progress: bool | None,
    x0: np.ndarray | None,
):
    """Two-phase SLSQP multistart (see :class:`MultistartOptions`); returns (x, history, extra).

    ``history``: best criterion value (on the full problem's samples) after each polished candidate,
    preceded by phase 1's best values per start (on the search samples)."""
    for key in ("starts", "screen", "polish", "maxiter", "polish_maxiter", "stop_after", "polish_grid"):
        value = getattr(opts, key)
        if int(value) != value or value < 1:
            raise SpecError(f"slsqp: {key} {value!r}, expected a positive integer")
    if opts.stop_ratio != 0 and opts.stop_ratio < 1:
        raise SpecError(f"slsqp: stop_ratio {opts.stop_ratio!r}, expected ≥ 1 (or 0: never stop a start early)")
    if opts.workers is not None and (int(opts.workers) != opts.workers or opts.workers < 1):
        raise SpecError(f"slsqp: workers {opts.workers!r}, expected a positive integer")
    if opts.limits not in ("grid", "peaks"):
        raise SpecError(f"slsqp: limits {opts.limits!r}, expected 'grid' or 'peaks'")
    peaks = opts.limits == "peaks"
    start_time = time.perf_counter()
    spec = problem.spec
    ns = opts.search_samples or max(50, 12 * spec.harmonics)
    ns = int(min(ns, spec.samples))
    if ns * problem.nv < problem.base.count:
        ns = spec.samples
    search = DesignProblem(problem.model, spec.replace(samples=ns), check_samples=2 * ns, base=problem.base)
    lower, upper = search.box()
    n_screen = opts.starts * opts.screen
    X = search.scale_into_limits(lower + rng.random((n_screen, search.d)) * (upper - lower))
    values = np.concatenate([search.evaluate(X[i : i + 256]) for i in range(0, n_screen, 256)])
    starts = X[np.argsort(values, kind="stable")[: opts.starts]]
    if x0 is not None:
        starts = np.vstack([search.scale_into_limits(np.atleast_2d(x0)), starts])[: opts.starts]
    found: list[tuple[float, np.ndarray]] = []
    history: list[float] = []
    best, stopped = np.inf, 0
    n_workers = pool_size(opts.workers, min(len(starts), BATCH))
    tell = _Estimate(len(starts), opts.polish, n_workers, start_time, enabled=progress, limits=opts.limits)
    polish = problem
    if len(problem.check_times) != opts.polish_grid:
        polish = DesignProblem(problem.model, spec, check_samples=int(opts.polish_grid), base=problem.base)
    problems = {"search": search, "polish": polish}
    with (
        SearchWorkers(_local_search, problems, n_workers) as workers,
        progress_bar(len(starts) + opts.polish, "slsqp", enabled=progress) as bar,
    ):
        for first in range(0, len(starts), BATCH):
            if opts.time_limit is not None and first > 0 and time.perf_counter() - start_time > opts.time_limit:
                break
            # a start more than stop_ratio times worse than the best of the batches before after stop_after
            # iterations is given up; the batches make that independent of the number of workers
            limit = best * opts.stop_ratio if opts.stop_ratio and np.isfinite(best) else np.inf
            tasks = [
                ("search", xs, opts.maxiter, opts.ftol, (opts.stop_after, limit), peaks)
                for xs in starts[first : first + BATCH]
            ]
            for (x, value, nit), _ in workers.map(tasks, each=tell.first_start):
                found.append((value, x))
                stopped += nit < 0
                best = min(best, value)
                history.append(best)
            bar.update(len(tasks))
            # phase 1's values are on the search grid (ns samples per period), not the design's: say so, so
            # that the polished result (on the design's samples, the value reported) is not read as worse
            bar.set_postfix_str(f"search best {best:.6g} ({ns} samples/period)", refresh=False)
        found.sort(key=lambda r: r[0])
        chosen: list[np.ndarray] = []
        for value, x in found:  # distinct candidates only
            if len(chosen) == opts.polish or not np.isfinite(value):
                break
            if all(np.linalg.norm(x - c) > 1e-6 * (1 + np.linalg.norm(c)) for c in chosen):
                chosen.append(x)
        chosen = [problem.scale_into_limits(x[None, :])[0] for x in chosen]
        tasks = [("polish", x, opts.polish_maxiter, opts.polish_ftol, None, peaks) for x in chosen]
        best_x, best_f = None, np.inf
        polished = []
        for x_start, ((x, value, _), _) in zip(chosen, workers.map(tasks)):
            x, value = _never_worse(problem, x_start, x, value)
            polished.append(value)
            if value < best_f:
                best_x, best_f = x, value
            history.append(best_f)
            bar.update(1)
            bar.set_postfix_str(f"polished best {best_f:.6g}", refresh=False)  # the design's criterion
    if best_x is None:
        best_x = problem.scale_into_limits(starts[:1])[0]
    return (
        best_x,
        history,
        {
            "starts_run": len(found),
            "starts_stopped_early": stopped,
            "search_samples": ns,
            "search_nfev": search.nfev + (polish.nfev if polish is not problem else 0),
            "search_regressor_samples": search.regressor_samples
            + (polish.regressor_samples if polish is not problem else 0),
            "polished_values": polished,
            "workers": max(n_workers, 1),
        },
    )


def _never_worse(problem: DesignProblem, x_start: np.ndarray, x: np.ndarray, value: float) -> tuple[np.ndarray, float]:
    """The polished ``x`` (criterion ``value``) or its start ``x_start``, whichever is better on the full
    problem once both are within the limits on the dense grid (:func:`_final_repair`), as the result will be."""
    out = []
    for y, v in ((x, value), (x_start, None)):
        repaired, _ = _final_repair(problem, y)
        if v is None or not np.array_equal(repaired, y):
            _, values = _scaled_values(problem, repaired[None, :], problem.spec.has_torque_limits)
            v = float(values[0])
        out.append((repaired, v))
    return out[0] if out[0][1] <= out[1][1] else out[1]


class _Estimate:
    """Says on stderr, once the first start of phase 1 is done, how long the design will take when that
    is more than :data:`LONG` seconds: phase 1 from the first start's time (a fraction
    share of the starts run to the end), each polish some starts: :data:`ESTIMATE_COSTS` of ``limits``."""

    def __init__(
        self, starts: int, polish: int, workers: int, start_time: float, enabled: bool | None, limits: str = "grid"
    ) -> None:
        from pinid.progress import shown

        self.starts, self.polish, self.workers, self.start_time = starts, polish, max(workers, 1), start_time
        self.enabled, self.said = shown(enabled), False
        self.costs = ESTIMATE_COSTS[limits]

    def first_start(self, index: int, seconds: float) -> None:
        if self.said or not self.enabled:
            return
        self.said = True
        share, polish_cost = self.costs
        rounds = -(-self.starts // self.workers) * share + -(-self.polish // self.workers) * polish_cost
        total = time.perf_counter() - self.start_time + max(rounds - 1, 0) * seconds
        if total >= LONG:
            print(
                f"pinid: slsqp: about {total:.0f} s ({self.starts} starts, {self.polish} polished, "
                f"{self.workers} process{'es' if self.workers > 1 else ''})",
                file=sys.stderr,
                flush=True,
            )


def _metaheuristic(problem: DesignProblem, opt, rng: np.random.Generator, progress: bool | None, x0: np.ndarray | None):
    """A population-based optimiser on the box; limits by scaling (kinematic) and penalty (torque)."""
    lower, upper = problem.box()
    torque = problem.spec.has_torque_limits

    def fitness(X: np.ndarray) -> np.ndarray:
        Xs = problem.scale_into_limits(X)
        if not torque:
            return problem.evaluate(Xs)
        values, tau = problem.evaluate(Xs, torque=True)
        viol = problem.torque_violation(tau)
        return np.where(viol > 0, 1e6 * (1 + viol) + values, values)

    res = opt.minimize(fitness, lower, upper, rng=rng, x0=x0, progress=progress)
    x = problem.scale_into_limits(res.x[None, :])[0]
    return x, res.history, {"message": res.message, "iterations": res.nit}
