"""Output-error identification of flexible-joint robots (seed 003, Section 3).

The drive parameters of :mod:`pinid.flexible.model` enter the dynamics nonlinearly, so they are not fitted
on a regressor: the model is *simulated* under the measured input and the parameters that make the
simulated angles match the measured ones are searched for.  Costs, over the samples ``i`` and the
measured angles ``j`` (link angles, and motor angles when measured and asked for)::

    "abs":  J = Σ_i Σ_j |e_ij|          seed 003 Eq. (15) [rad]
    "sq":   J = Σ_i Σ_j e_ij²           [rad²]

with ``e = simulated − measured``.  Every metaheuristic of :data:`pinid.optimizers.OPTIMIZERS` (pso,
woa, ewoa, de) minimises it through the same interface: the whole population is simulated at once
(:meth:`~pinid.flexible.model.FlexibleModel.simulate`).  ``"least_squares"`` is scipy's trust-region
reflective least squares, a gradient-based comparison: it minimises the squared error (``"sq"``), or for
``"abs"`` its ``soft_l1`` loss with ``f_scale`` [rad] (≈ |e| for |e| ≫ f_scale), in coordinates scaled
to the box; its finite-difference Jacobian is one batch simulation of ``d + 1`` parameter sets.

What is here
------------
* :func:`make_twin` — a recording simulated with known parameters, with seeded Gaussian noise.
* :class:`OutputErrorProblem` — simulated-vs-measured angles as a batch cost, residuals, Jacobian.
* :func:`fit_output_error` → :class:`~pinid.flexible.result.OutputErrorResult` (fitted values, error against
  the truth, cost curve, time); :func:`sensitivity` — which parameters the excitation makes observable;
  :func:`compare_rigid_flexible` — seed 003 Figs. 6-7.

Beside it (and re-exported here, where callers import them from): :mod:`pinid.flexible.recording`
(:class:`InputSignal`, :class:`FlexRecording`), :mod:`pinid.flexible.spec` (:class:`FlexSpec`,
:func:`load_flex_spec`, :data:`COSTS`, :data:`OUTPUTS`, :func:`methods`) and :mod:`pinid.flexible.result`.
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from pinid.errors import DataError, SolverError, SpecError
from pinid.flexible.model import FLEX_PARAMS, FlexibleModel, FlexSimulation
from pinid.optimizers import get_optimizer
from pinid.flexible.recording import FlexRecording, InputSignal
from pinid.flexible.result import OutputErrorResult
from pinid.flexible.spec import (
    COSTS,
    LEAST_SQUARES,
    OUTPUTS,
    FlexSpec,
    methods,
)


# ====================================================================== twin
def make_twin(
    model: FlexibleModel,
    signal: InputSignal | tuple[np.ndarray, np.ndarray],
    *,
    noise: float = 0.0,
    rng: np.random.Generator | int | None = 0,
    q0: np.ndarray | None = None,
    refine: int = 4,
    motor: bool = True,
) -> FlexRecording:
    """Simulate ``model`` (its values are the truth) and return a recording with seeded noise.

    ``signal``: an :class:`InputSignal` or ``(t, u)``; ``noise``: standard deviation [rad] of the Gaussian
    noise added to every measured angle (link and motor); ``refine``: the twin integrates with a step
    ``refine`` times smaller than a fit would (so that fitting does not reuse the exact same discretisation);
    ``motor``: also record the motor angles.  ``meta["truth"]`` holds every parameter value.
    """
    if not isinstance(model, FlexibleModel):
        raise SpecError(f"model: got {type(model).__name__}, expected a FlexibleModel")
    if isinstance(signal, InputSignal):
        t, u = signal.generate(model.joint_names)
        kind = signal.kind
    else:
        t, u = (np.asarray(a, dtype=float) for a in signal)
        kind = "torque"
    if not isinstance(rng, np.random.Generator):
        rng = np.random.default_rng(0 if rng is None else rng)
    dt = float(t[1] - t[0])
    q0 = np.zeros(model.nv) if q0 is None else np.asarray(q0, dtype=float)
    h, _ = model.choose_step(dt, model.values[None, :], q0)
    sim = model.simulate(u, dt, q0=q0, input=kind, step=h / max(1, int(refine)))
    if sim.diverged[0]:
        raise SolverError("twin simulation diverged: the truth values give a non-finite state")
    q = sim.q[0] + (noise * rng.standard_normal(sim.q[0].shape) if noise > 0 else 0.0)
    qm = None
    if motor:
        qm = sim.qm[0] + (noise * rng.standard_normal(sim.qm[0].shape) if noise > 0 else 0.0)
    meta = {
        "twin": True,
        "noise": float(noise),
        "step": float(sim.step),
        "truth": dict(zip(model.names, map(float, model.values))),
        "drives": [{"joint": d.joint, "ratio": d.ratio, "flexible": d.flexible} for d in model.drives],
    }
    return FlexRecording(t, u, q, list(model.joint_names), qm, kind, "<twin>", meta)


# ====================================================================== the problem
@dataclass(frozen=True)
class FreeParameters:
    """The parameters an :class:`OutputErrorProblem` fits: their ``names`` (of the model's parameters) and
    their box, one ``lower`` and one ``upper`` bound per name (the problem checks the shapes and the
    order).  A wrong type: SpecError (one line)."""

    names: Sequence[str]
    lower: Sequence[float]
    upper: Sequence[float]

    def __post_init__(self) -> None:
        names = self.names
        if isinstance(names, str) or not isinstance(names, Sequence) or not all(isinstance(n, str) for n in names):
            raise SpecError(f"FreeParameters names: got {names!r}, expected a list of parameter names")
        for key in ("lower", "upper"):
            value = getattr(self, key)
            if isinstance(value, (str, Mapping)) or not np.iterable(value):
                raise SpecError(f"FreeParameters {key}: got {type(value).__name__}, expected one number per name")


class OutputErrorProblem:
    """Simulated against measured angles, as a function of the free parameters.

    ``model``: gives the fixed values and the structure; ``recording``: input and measured angles;
    ``free``: the fitted parameters and their box (:class:`FreeParameters`); ``cost``: ``"abs"`` or ``"sq"``;
    ``outputs``: ``("link",)`` (seed 003) and/or ``"motor"``; ``rest_time`` [s]: the initial link angles
    are the mean of the measured ones over ``[t0, t0 + rest_time]`` (at least the first sample).
    The RK4 step is fixed for the problem, from the worst corner of the box (:meth:`_choose_step`), so that
    every candidate is integrated stably with the same step.
    """

    def __init__(
        self,
        model: FlexibleModel,
        recording: FlexRecording,
        free: FreeParameters,
        *,
        cost: str = "abs",
        outputs: Sequence[str] = ("link",),
        rest_time: float = 0.0,
        step: float | None = None,
        truth: Mapping[str, float] | None = None,
        label: str = "",
    ) -> None:
        if not isinstance(free, FreeParameters):
            raise SpecError(f"free: got {type(free).__name__}, expected FreeParameters(names, lower, upper)")
        if cost not in COSTS:
            raise SpecError(f"cost {cost!r}, expected one of {', '.join(COSTS)}")
        outputs = tuple(outputs)
        if not outputs or any(o not in OUTPUTS for o in outputs):
            raise SpecError(f"outputs {outputs!r}, expected some of {', '.join(OUTPUTS)}")
        self.model = model
        self.recording = recording.reorder(model.joint_names)
        if "motor" in outputs and self.recording.qm is None:
            raise DataError(
                f"{recording.source}: no motor angles qm_<joint>, but the fit compares motor angles "
                "(outputs = ['link', 'motor']); use outputs = ['link']"
            )
        self.free = list(free.names)
        self.idx = np.array([model.index(n) for n in self.free], dtype=int)
        self.lower = np.asarray(free.lower, dtype=float).reshape(-1)
        self.upper = np.asarray(free.upper, dtype=float).reshape(-1)
        if self.lower.shape != (len(self.free),) or self.upper.shape != (len(self.free),):
            raise SpecError(f"bounds of shapes {self.lower.shape}, {self.upper.shape}, expected ({len(self.free)},)")
        if np.any(self.lower >= self.upper):
            i = int(np.argmax(self.lower >= self.upper))
            raise SpecError(f"{self.free[i]}: bounds [{self.lower[i]:g}, {self.upper[i]:g}], expected lower < upper")
        self.cost_kind = cost
        self.outputs = outputs
        self.truth = dict(truth) if truth else None
        self.label = label
        rec = self.recording
        self.dt = rec.dt
        k = max(1, int(np.searchsorted(rec.t, rec.t[0] + rest_time, side="right")))
        self.q0 = rec.q[:k].mean(axis=0)
        meas = [rec.q]
        if "motor" in outputs:
            meas.append(rec.qm)
        self.measured = np.concatenate(meas, axis=1)  # (N, k·nv)
        self.step = float(step) if step else self._choose_step()
        self.nsim = 0
        self.seconds = 0.0

    @property
    def d(self) -> int:
        """Number of fitted parameters."""
        return len(self.free)

    def full(self, X: np.ndarray) -> np.ndarray:
        """Full parameter vectors ``(P, D)`` from free ones ``(P, d)``."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        out = np.repeat(self.model.values[None, :], len(X), axis=0)
        out[:, self.idx] = X
        return out

    def _choose_step(self) -> float:
        """Stable for the worst corner of the box (the fastest rates come with high stiffness, damping and
        friction and low inertias; free inertial parameters are tried at both bounds and at 64 random points),
        accurate for the model's values (the truth of a twin, else the middle of the box)."""
        lo, hi = self.lower, self.upper
        worst = np.empty(self.d)
        for i, n in enumerate(self.free):
            par = n.rsplit(".", 1)[-1]
            if par in ("Jm",):
                worst[i] = lo[i]
            elif par in ("K2", "kv"):
                worst[i] = lo[i] if abs(lo[i]) > abs(hi[i]) else hi[i]
            elif par in FLEX_PARAMS:
                worst[i] = hi[i]
            else:
                worst[i] = np.nan
        inert = np.isnan(worst)
        rng = np.random.default_rng(12345)
        probes = [
            np.where(inert, lo, worst),
            np.where(inert, hi, worst),
            np.where(inert, self.model.values[self.idx], worst),
        ]
        rnd = lo + rng.random((64, self.d)) * (hi - lo)
        rnd[:, ~inert] = worst[~inert]
        X = np.vstack(probes + [rnd])
        h, _ = self.model.choose_step(self.dt, self.full(X), self.q0, accuracy=self.model.values[None, :])
        return h

    # ------------------------------------------------------------------ evaluation
    def simulate(self, X) -> FlexSimulation:
        """Simulate free parameter vectors ``(P, d)`` (or one ``(d,)``) under the recording's input."""
        start = time.perf_counter()
        sim = self.model.simulate(
            self.recording.u, self.dt, self.full(X), q0=self.q0, input=self.recording.input, step=self.step
        )
        self.nsim += sim.q.shape[0]
        self.seconds += time.perf_counter() - start
        return sim

    def errors(self, X) -> np.ndarray:
        """Simulated minus measured angles ``(P, N, k·nv)`` [rad] (link angles, then motor angles)."""
        sim = self.simulate(X)
        parts = [sim.q]
        if "motor" in self.outputs:
            parts.append(sim.qm)
        return np.concatenate(parts, axis=2) - self.measured[None]

    def cost_of_errors(self, e: np.ndarray) -> np.ndarray:
        """The cost of angle errors ``e`` (P, samples, channels) [rad]: Σ|e| (seed 003 Eq. (15)) or Σe²; inf where not finite."""
        with np.errstate(all="ignore"):
            c = np.abs(e).sum(axis=(1, 2)) if self.cost_kind == "abs" else (e * e).sum(axis=(1, 2))
        return np.where(np.isfinite(c), c, np.inf)

    def cost_batch(self, X: np.ndarray) -> np.ndarray:
        """The cost of every row of ``X`` ``(P, d)``: one batch simulation."""
        return self.cost_of_errors(self.errors(X))

    def cost(self, x) -> float:
        """The cost of one parameter vector ``x``."""
        return float(self.cost_batch(np.atleast_2d(x))[0])

    def integrator_error(self, x, refine: int = 4) -> float:
        """Largest difference [rad] of the link angles at ``x`` between the problem's step and a ``refine`` times
        smaller one: the integrator's tolerance at that point."""
        full = self.full(np.atleast_2d(x))
        a = self.model.simulate(self.recording.u, self.dt, full, q0=self.q0, input=self.recording.input, step=self.step)
        b = self.model.simulate(
            self.recording.u, self.dt, full, q0=self.q0, input=self.recording.input, step=self.step / refine
        )
        return float(np.max(np.abs(a.q - b.q)))

    def metrics(self, x) -> dict:
        """Per joint (and output) RMS, mean and max absolute angle error [rad] at ``x``."""
        e = self.errors(np.atleast_2d(x))[0]
        names = [f"{j}" for j in self.model.joint_names]
        if "motor" in self.outputs:
            names += [f"{j}.motor" for j in self.model.joint_names]
        out = {}
        for k, n in enumerate(names):
            ek = e[:, k]
            out[n] = {
                "rms": float(np.sqrt(np.mean(ek**2))),
                "mean_abs": float(np.mean(np.abs(ek))),
                "max_abs": float(np.max(np.abs(ek))),
            }
        return out


# ====================================================================== fitting
def fit_output_error(
    problem: OutputErrorProblem,
    method: str = "pso",
    *,
    rng: np.random.Generator | int | None = 0,
    x0=None,
    options: Mapping | None = None,
    progress: bool | None = None,
    f_scale: float = 1e-3,
    max_nfev: int = 60,
) -> OutputErrorResult:
    """Fit the free parameters of ``problem`` with ``method`` (a registry optimiser or ``"least_squares"``).

    ``options``: settings of the optimiser (``population``, ``iterations``, …); ``x0``: a start (free values)
    put in the initial population, or least squares' start (default: the middle of the box);
    ``f_scale`` [rad]: least squares' soft-L1 scale when the cost is ``"abs"``; ``max_nfev``: least squares'
    budget of residual evaluations (each Jacobian costs one more batch of ``d`` simulations).
    """
    if not isinstance(problem, OutputErrorProblem):
        raise SpecError(f"problem: got {type(problem).__name__}, expected an OutputErrorProblem (problem_from_spec)")
    if method not in methods():
        raise SpecError(f"unknown method {method!r}, expected one of {', '.join(methods())}")
    start = time.perf_counter()
    nsim0 = problem.nsim
    history: list[list[float]] = []
    if method == LEAST_SQUARES:
        x, message, extra = _least_squares(problem, x0, history, f_scale, max_nfev, options or {}, progress)
    else:
        opt = get_optimizer(method, **dict(options or {}))

        def fun(X):
            return problem.cost_batch(X)

        def callback(it, xb, fb):
            history.append([problem.nsim - nsim0, float(fb)])
            return None

        res = opt.minimize(fun, problem.lower, problem.upper, rng=rng, x0=x0, callback=callback, progress=progress)
        if not history or history[0][0] != 0:
            history.insert(0, [0, float(res.history[0])])
        x, message = res.x, res.message
        extra = {"iterations": int(res.nit), "options": {k: v for k, v in vars(opt.options).items()}}
    seconds = time.perf_counter() - start
    nfev = problem.nsim - nsim0
    cost = problem.cost(x)
    metrics = problem.metrics(x)
    extra["integrator_error"] = problem.integrator_error(x)
    kind = "flexible" if problem.model.flexible_joints else "rigid"
    truth = None
    if problem.truth:
        truth = {n: float(problem.truth[n]) for n in problem.free if n in problem.truth}
    return OutputErrorResult(
        method,
        kind,
        problem.cost_kind,
        list(problem.free),
        np.asarray(x, float),
        problem.lower.copy(),
        problem.upper.copy(),
        cost,
        history,
        nfev,
        seconds,
        message,
        problem.step,
        metrics,
        truth,
        extra,
    )


def _least_squares(problem: OutputErrorProblem, x0, history, f_scale, max_nfev, options, progress=None):
    from scipy.optimize import least_squares

    from pinid.progress import progress as progress_bar

    lo, hi = problem.lower, problem.upper
    width = hi - lo
    z0 = 0.5 * np.ones(problem.d) if x0 is None else np.clip((np.asarray(x0, float).reshape(-1) - lo) / width, 0, 1)
    if z0.shape != (problem.d,):
        raise SpecError(f"least_squares: x0 has {z0.size} values, expected {problem.d}")
    best = {"cost": np.inf}
    nsim0 = problem.nsim
    diff = float(options.get("diff_step", 1e-6))

    def residuals(z):
        e = problem.errors((lo + z * width)[None, :])
        c = float(problem.cost_of_errors(e)[0])
        best["cost"] = min(best["cost"], c)
        history.append([problem.nsim - nsim0, best["cost"]])
        bar.update(1)
        bar.set_postfix_str(f"best {best['cost']:.6g}", refresh=False)
        r = e[0].reshape(-1)
        if not np.all(np.isfinite(r)):
            return np.full(r.shape, 1e3)  # diverged: a large, finite residual
        return r

    def jacobian(z):
        steps = np.where(z + diff <= 1.0, diff, -diff)
        Z = np.vstack([z] + [z + np.eye(problem.d)[i] * steps[i] for i in range(problem.d)])
        e = problem.errors(lo + Z * width).reshape(len(Z), -1)
        J = (e[1:] - e[:1]) / steps[:, None]
        J[~np.isfinite(J)] = 0.0
        return J.T

    kw = dict(
        method="trf",
        jac=jacobian,
        bounds=(np.zeros(problem.d), np.ones(problem.d)),
        x_scale=1.0,
        ftol=float(options.get("ftol", 1e-12)),
        xtol=float(options.get("xtol", 1e-12)),
        gtol=float(options.get("gtol", 1e-12)),
        max_nfev=int(options.get("max_nfev", max_nfev)),
    )
    if problem.cost_kind == "abs":
        kw.update(loss="soft_l1", f_scale=float(f_scale))
    bar = progress_bar(kw["max_nfev"], "least_squares", enabled=progress)
    try:
        res = least_squares(residuals, z0, **kw)
    finally:
        bar.close()
    return (
        lo + res.x * width,
        str(res.message),
        {
            "njev": int(res.njev or 0),
            "status": int(res.status),
            "f_scale": float(f_scale) if problem.cost_kind == "abs" else None,
        },
    )


# ====================================================================== observability
def sensitivity(problem: OutputErrorProblem, x=None, *, noise: float = 1e-3, rel_step: float = 1e-5) -> dict:
    """Which free parameters the recording's excitation makes observable, at ``x`` (default: the truth).

    ``S[k, i] = ∂e_k/∂ln|x_i|`` (finite differences, one batch simulation) — the change of every compared
    angle for a 1 % change of a parameter, ×100.  Returns the singular values of ``S`` (a value near 0: a
    combination of parameters the angles do not see), each parameter's relative standard deviation
    ``σ·√((SᵀS)⁻¹)_ii`` for Gaussian angle noise ``noise`` [rad] (Cramér-Rao bound of least squares), and the
    weakest direction (the right singular vector of the smallest singular value).
    """
    if not isinstance(problem, OutputErrorProblem):
        raise SpecError(f"problem: got {type(problem).__name__}, expected an OutputErrorProblem (problem_from_spec)")
    if x is None:
        if not problem.truth or any(n not in problem.truth for n in problem.free):
            x = problem.model.values[problem.idx]
        else:
            x = np.array([problem.truth[n] for n in problem.free])
    x = np.asarray(x, dtype=float)
    scale = np.where(x != 0, np.abs(x), problem.upper - problem.lower)
    h = rel_step * scale
    X = np.vstack([x] + [x + np.eye(problem.d)[i] * h[i] for i in range(problem.d)])
    e = problem.errors(X).reshape(len(X), -1)
    S = ((e[1:] - e[:1]) / h[:, None] * scale[:, None]).T  # (rows, d): per unit relative change
    U, s, Vt = np.linalg.svd(S, full_matrices=False)
    tiny = s < s[0] * 1e-12
    inv = np.where(tiny, np.inf, 1.0 / np.where(tiny, 1.0, s) ** 2)
    with np.errstate(invalid="ignore"):
        var = (Vt.T**2 * inv[None, :]).sum(axis=1)
    rel_std = noise * np.sqrt(var)
    return {
        "names": list(problem.free),
        "x": x.tolist(),
        "singular_values": s.tolist(),
        "condition": float(s[0] / s[-1]) if s[-1] > 0 else float("inf"),
        "rel_std": dict(zip(problem.free, map(float, rel_std))),
        "noise": float(noise),
        "weakest": dict(zip(problem.free, map(float, Vt[-1]))),
        "samples": int(e.shape[1]),
    }


#: Relative standard deviations [-] that :func:`classify` calls well determined and weak.
WELL_DETERMINED = 0.01
WEAK = 0.1


def classify(rel_std: float) -> str:
    """``"observable"`` (±2σ within ±2 %), ``"weak"`` (σ ≤ 10 %) or ``"unobservable"`` at the noise of the bound."""
    if isinstance(rel_std, bool) or not isinstance(rel_std, (int, float, np.floating, np.integer)):
        raise SpecError(f"rel_std: got {type(rel_std).__name__}, expected a relative standard deviation (a number)")
    if rel_std <= WELL_DETERMINED:
        return "observable"
    return "weak" if rel_std <= WEAK else "unobservable"


# ====================================================================== spec-level helpers
def problem_from_spec(
    spec: FlexSpec,
    recording: FlexRecording,
    *,
    rigid: bool = False,
    cost: str | None = None,
    outputs: Sequence[str] | None = None,
) -> OutputErrorProblem:
    """The problem a spec describes for ``recording`` (``rigid``: the rigid-joint model of the same spec)."""
    if not isinstance(spec, FlexSpec):
        raise SpecError(f"spec: got {type(spec).__name__}, expected a FlexSpec (load_flex_spec)")
    s = spec.rigid() if rigid else spec
    model = s.model()
    truth = None  # the rigid model has no truth: the twin is flexible
    if not rigid and (s.truth is not None or recording.meta.get("truth")):
        truth = {**(s.truth or {}), **(recording.meta.get("truth") or {})}  # what made the recording wins
    return OutputErrorProblem(
        model,
        recording,
        FreeParameters(s.free, s.lower, s.upper),
        cost=cost or s.fit.cost,
        outputs=outputs or s.fit.outputs,
        rest_time=s.fit.rest_time,
        truth=truth,
        label="rigid" if rigid else "flexible",
    )


def compare_rigid_flexible(
    spec: FlexSpec,
    recording: FlexRecording,
    *,
    method: str | None = None,
    options: Mapping | None = None,
    rng: int = 0,
    polish: bool = True,
    progress: bool | None = None,
) -> dict:
    """Seed 003 Figs. 6-7: fit the flexible and the rigid model of ``spec`` to the same recording.

    Each model is fitted with ``method`` (default the spec's), then, if ``polish``, refined by least squares
    from that result.  Returns ``{"flexible": result, "rigid": result, "simulated": {label: (N, nv)},
    "measured": (N, nv), "t": (N,)}``.
    """
    if not isinstance(spec, FlexSpec):
        raise SpecError(f"spec: got {type(spec).__name__}, expected a FlexSpec (load_flex_spec)")
    method = method or spec.fit.method
    opts = dict(options or {"population": spec.fit.population, "iterations": spec.fit.iterations})
    out: dict = {"t": recording.t, "measured": recording.reorder(spec.robot.joint_names).q, "simulated": {}}
    for label, rigid in (("flexible", False), ("rigid", True)):
        prob = problem_from_spec(spec, recording, rigid=rigid)
        res = fit_output_error(
            prob,
            method,
            rng=rng,
            options=None if method == LEAST_SQUARES else opts,
            progress=progress,
            f_scale=spec.fit.f_scale,
        )
        if polish and method != LEAST_SQUARES:
            ls = fit_output_error(prob, LEAST_SQUARES, x0=res.x, f_scale=spec.fit.f_scale, progress=progress)
            if ls.cost <= res.cost:
                ls.history = res.history + [[res.nfev + h[0], min(h[1], res.cost)] for h in ls.history]
                ls.extra["global"] = {"method": method, "cost": res.cost, "nfev": res.nfev, "seconds": res.seconds}
                ls.method = f"{method}+least_squares"
                ls.nfev += res.nfev
                ls.seconds += res.seconds
                res = ls
        out[label] = res
        out["simulated"][label] = prob.simulate(res.x).q[0]
    return out
