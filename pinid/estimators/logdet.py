"""Physically consistent least squares pulled toward the URDF by the log-det divergence (issue 34, item 3).

Lee, Wensing & Park (2020), "Geometric robot dynamic identification: a convex programming approach"
(IEEE T-RO 36(2)): the prior is measured between pseudo-inertia matrices with the Bregman divergence of
``−log det`` (the entropic divergence of the mass distributions)::

    d(J ‖ J₀) = −log det J + log det J₀ + tr(J₀⁻¹ J) − 4        ≥ 0, zero only at J = J₀

It is invariant to a change of frame or of units of the body (``J → T J Tᵀ``), so one weight serves every
body; ``J ≻ 0`` (physical consistency) is implied by its domain.  Problem, in the scaled coordinates
``z = θ/S`` of :class:`~pinid.estimators.sdp.SDP`::

    minimise    ‖R·C·P·θ − c‖² / ‖y‖²  +  λ·( Σ_i d(J_i(θ) ‖ J_i(θ_URDF))  +  ‖(θ_t − θ_t,URDF)/S_t‖² )
    subject to  fc ≥ 0, fv ≥ 0, armature ≥ 0        (the joint terms θ_t, as sdp constrains them)

The data term is the squared excess residual of the compressed problem (as sdp states it, squared: the
prior then trades against it as a Gaussian likelihood would).  A URDF pseudo-inertia that is singular (a
massless link, an inertia of zero) is lifted by 1e-6 of its scale so that ``J₀⁻¹`` exists.

The weight λ: ``weight`` a number, or ``"auto"`` (default): chosen on :data:`GRID` by blocked
cross-validation on the training rows: :data:`FOLDS` contiguous blocks of the rows (rows are stacked
sample-major, so blocks of samples in time), the estimator refitted on all blocks but one, the held-out
block scored by its relative RMS error against the torque as recorded; the λ of the lowest mean wins (the
smallest of a tie within 1e-9).  ``info_`` gives λ and the curve.  Solved with cvxpy and Clarabel
(exponential and PSD cones), the problem compiled once with λ and the data as parameters.
"""

from __future__ import annotations

import warnings

import numpy as np

from pinid.errors import SolverError, SpecError
from pinid.estimators.base import Estimator, Setting
from pinid.linalg import augmented_r, cholesky_r, gram_sums, row_blocks, unit_weights
from pinid.model import terms as _terms
from pinid.model.lmi import clip_terms, pseudo_inertia_map
from pinid.model.physical import check_consistency, parameter_scale

#: Candidate weights λ of the automatic choice (dimensionless: the data term is relative).
GRID = tuple(float(x) for x in np.logspace(-8, 2, 11))
#: Contiguous blocks of the rows in the cross-validation.
FOLDS = 5


def _one_thread() -> dict:
    """Clarabel on one thread, as :mod:`pinid.model.conic`: a thread pool started here would leave a worker
    process forked after it waiting for ever (Clarabel ≥ 0.10 has ``max_threads``; 0.9 has no pool)."""
    import clarabel

    return {"max_threads": 1} if hasattr(clarabel.DefaultSettings(), "max_threads") else {}


class LogDet(Estimator):
    """Physically consistent least squares with the log-det divergence toward the URDF (see the module text).

    Settings: ``weight`` (λ ≥ 0, or "auto": chosen by blocked cross-validation on :data:`GRID`),
    ``solver_options`` (dict passed to Clarabel through cvxpy).
    """

    name = "logdet"
    summary = (
        "physically consistent least squares pulled toward the URDF by the log-det (Bregman) divergence of "
        "every body's pseudo-inertia (Lee, Wensing & Park 2020), cvxpy + Clarabel; its weight λ chosen by "
        "blocked cross-validation"
    )
    assumptions = "as `sdp`, plus: the URDF is a useful prior, how useful the held-out rows decide"
    settings_summary = (
        '`weight` ("auto": λ on 1e-8 … 1e2 by 5 contiguous blocks of the training rows; or a number ≥ 0), '
        "`solver_options`"
    )
    description = "physically consistent least squares pulled toward the URDF by the log-det divergence"
    consistent_by_construction = True
    in_defaults = False
    colour = "#7fff00"
    settings = {
        "weight": Setting("any", help='λ of the log-det divergence toward the URDF (≥ 0), or "auto" (cross-validated)'),
        "solver_options": Setting("dict", optional=True, help="passed to Clarabel"),
    }

    def __init__(self, weight="auto", solver_options: dict | None = None) -> None:
        self.weight = weight
        self.solver_options = solver_options

    @classmethod
    def create(cls, **settings) -> "LogDet":
        """An instance with checked settings; a bad ``weight`` is a SpecError here, before any data is read."""
        if "weight" in settings:
            _check_weight(settings["weight"])
        return super().create(**settings)

    # ------------------------------------------------------------------ fit
    def fit(self, problem) -> "LogDet":
        """Fit (λ chosen first when ``weight="auto"``); sets ``base_``, ``standard_``, ``status_``, ``info_``."""
        weight = _check_weight(self.weight)
        if not hasattr(problem, "base") or not hasattr(problem, "nominal"):
            raise SpecError(
                "logdet: needs the full identification problem (the standard parameters of every body); "
                "not a segmental stage"
            )
        prog = _Program(problem, self.solver_options)
        info: dict = {"solver": "CLARABEL"}
        if weight == "auto":
            weight, curve = _choose_weight(problem, prog)
            info["weight_chosen_by"] = f"blocked cross-validation, {FOLDS} blocks"
            info["curve"] = curve
        R, c, rho, scale = problem.compressed()
        theta, status = prog.solve(R, c, rho, scale, weight)
        report = check_consistency(theta, problem.model.joint_names, problem.terms.names, problem.model.motor_names)
        if not report.consistent:
            raise SolverError(f"logdet: status '{status}' but not physically consistent ({'; '.join(report.problems)})")
        self.standard_ = theta
        self.base_ = problem.base.P @ theta
        self.weights_ = None
        self.history_ = None
        self.status_ = status
        self.info_ = {**info, "weight": float(weight), "status": status, "divergence": prog.divergence(theta)}
        return self


def _check_weight(weight):
    if isinstance(weight, str) and weight.strip().lower() == "auto":
        return "auto"
    if isinstance(weight, (int, float, np.floating, np.integer)) and not isinstance(weight, bool):
        if np.isfinite(weight) and weight >= 0:
            return float(weight)
    raise SpecError(f"method 'logdet': setting weight={weight!r}, expected a number ≥ 0 or \"auto\"")


class _Program:
    """The cvxpy problem, compiled once: the data (``G``, ``g``) and λ are parameters."""

    def __init__(self, problem, solver_options: dict | None) -> None:
        import cvxpy as cp

        self.problem = problem
        self.options = dict(solver_options or {})
        nv, nt = problem.nv, len(problem.terms)
        P = problem.base.P
        self.P = P
        self.S = S = parameter_scale(problem.nominal, nv, nt)
        p = P.shape[1]
        z0 = problem.nominal / S
        self.z = z = cp.Variable(p)
        self.G = cp.Parameter((problem.nb, p))
        self.g = cp.Parameter(problem.nb)
        self.lam = cp.Parameter(nonneg=True)
        self.blocks, self.J0 = [], []
        prior = []
        for i in range(nv):
            B = pseudo_inertia_map(S, i, p)
            J0 = (B @ z0).reshape(4, 4, order="F")
            J0 = 0.5 * (J0 + J0.T)
            ev = np.linalg.eigvalsh(J0)
            floor = 1e-6 * max(float(np.trace(J0)), 1.0)
            if ev[0] < floor:  # a singular URDF body: lifted so that J0⁻¹ exists
                J0 = J0 + (floor - ev[0]) * np.eye(4)
            J0inv = np.linalg.inv(J0)
            J0inv = 0.5 * (J0inv + J0inv.T)
            F = cp.reshape(B @ z, (4, 4), order="F")
            J = 0.5 * (F + F.T)
            prior.append(-cp.log_det(J) + cp.trace(J0inv @ J) + float(np.linalg.slogdet(J0)[1]) - 4.0)
            self.blocks.append(B)
            self.J0.append(J0)
        t = np.arange(10 * nv, p)
        if t.size:
            prior.append(cp.sum_squares(z[t] - z0[t]))
        cons = []
        idx = 10 * nv + np.flatnonzero(_terms.nonnegative(problem.model, problem.terms))
        if idx.size:
            cons.append(z[idx] >= 0)
        self.prior = sum(prior)
        cost = cp.sum_squares(self.G @ z - self.g) + self.lam * self.prior
        self.cp_problem = cp.Problem(cp.Minimize(cost), cons)

    def solve(self, R, c, rho, colscale, weight: float) -> tuple[np.ndarray, str]:
        """θ minimising the cost for the compressed data ``(R, c, rho, colscale)`` and λ = ``weight``."""
        import cvxpy as cp

        norm_y = float(np.sqrt(c @ c + rho * rho)) or 1.0
        self.G.value = (R * colscale) @ self.P * self.S / norm_y
        self.g.value = c / norm_y
        self.lam.value = float(weight)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                self.cp_problem.solve(solver="CLARABEL", **{**_one_thread(), **self.options})
        except cp.error.SolverError as exc:
            raise SolverError(f"logdet: solver CLARABEL failed ({str(exc).strip().splitlines()[0]})") from None
        except OverflowError:  # older cvxpy (1.5) indexes a large parameterised problem's tensors in int32
            raise SolverError(
                f"logdet: cvxpy {cp.__version__} cannot compile a problem this large (an int32 overflow in its "
                "parameter tensors); expected a newer cvxpy (pip install -U cvxpy), or use sdp"
            ) from None
        status = str(self.cp_problem.status)
        if status not in ("optimal", "optimal_inaccurate") or self.z.value is None:
            raise SolverError(f"logdet: solver CLARABEL stopped with status '{status}'")
        return clip_terms(np.asarray(self.z.value, dtype=float) * self.S, self.problem), status

    def divergence(self, theta: np.ndarray) -> list[float]:
        """d(J_i ‖ J_i,URDF) of every body at ``θ``."""
        out = []
        for B, J0 in zip(self.blocks, self.J0):
            J = (B @ (theta / self.S)).reshape(4, 4, order="F")
            J = 0.5 * (J + J.T)
            sign, logdet = np.linalg.slogdet(J)
            d = -logdet + np.linalg.slogdet(J0)[1] + float(np.trace(np.linalg.solve(J0, J))) - 4.0
            out.append(float(d) if sign > 0 else float("inf"))
        return out


def _choose_weight(problem, prog: _Program) -> tuple[float, dict]:
    """λ of :data:`GRID` with the lowest mean held-out relative RMS over :data:`FOLDS` contiguous blocks."""
    W, tau = problem.W, problem.tau
    rec = problem.recorded_tau if getattr(problem, "recorded_tau", None) is not None else tau
    w = unit_weights(problem.weights)
    edges = np.linspace(0, problem.rows, FOLDS + 1).round().astype(int)
    sums = [
        gram_sums(row_blocks(W[a:b], tau[a:b], None if w is None else w[a:b]), problem.nb)
        for a, b in zip(edges[:-1], edges[1:])
    ]
    scores = np.full((len(GRID), FOLDS), np.nan)
    for f in range(FOLDS):
        G = sum(s[0] for k, s in enumerate(sums) if k != f)
        b = sum(s[1] for k, s in enumerate(sums) if k != f)
        yy = sum(s[2] for k, s in enumerate(sums) if k != f)
        out = cholesky_r(G, b, yy)
        if out is None:
            keep = np.r_[0 : edges[f], edges[f + 1] : problem.rows]
            out = augmented_r(W[keep], tau[keep], None if w is None else w[keep])
        a, e = edges[f], edges[f + 1]
        held, yh = W[a:e], rec[a:e]
        for g, lam in enumerate(GRID):
            try:
                theta, _ = prog.solve(*out, lam)
            except SolverError as exc:
                if "int32 overflow" in str(exc):  # the cvxpy release, not the weight: every fit would fail so
                    raise
                continue
            r = yh - held @ (prog.P @ theta)
            scores[g, f] = float(np.sqrt((r @ r) / max(float(yh @ yh), 1e-300)))
    mean = np.array([np.mean(s) if np.all(np.isfinite(s)) else np.inf for s in scores])
    if not np.any(np.isfinite(mean)):
        raise SolverError("logdet: every fit of the cross-validation failed")
    best = int(np.flatnonzero(mean <= mean.min() + 1e-9)[0])
    curve = {
        "weights": list(GRID),
        "heldout_relative_rms": [float(m) if np.isfinite(m) else None for m in mean],
        "chosen": GRID[best],
    }
    return GRID[best], curve


__all__ = ["FOLDS", "GRID", "LogDet"]
