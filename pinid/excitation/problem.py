"""The excitation design problem: its variables, the limits as constraints, the criterion and its gradient.

The trajectory of every joint is a finite Fourier series (seed 001 Eq. (19), :class:`FourierTrajectory`)
whose coefficients (and, if asked, offsets) are the variables of a :class:`DesignProblem`; it evaluates the
criterion of :mod:`pinid.excitation.evaluation` for a whole batch of candidates at once.

Start at rest
-------------
With ``rest_start`` (the default) dq(0) = ddq(0) = 0 — and so at the end of every period — by
construction: the first harmonic is eliminated, ``a_1 = −Σ_{k≥2} k a_k`` and ``b_1 = −Σ_{k≥2} k² b_k``,
so every optimiser gets it for free and it holds to rounding error.

Limits and gradient
-------------------
With the offsets fixed (or free), q, dq and ddq are *linear* in the design variables, so the kinematic
limits on a grid of the period are linear inequality constraints (:meth:`DesignProblem.linear_constraints`),
and a candidate can be scaled, per joint, into them (:meth:`DesignProblem.scale_into_limits`).  The
gradient of log cond(W_b) comes from the singular vectors of W_b and the derivatives of each sample's
regressor row with respect to that sample's state (:meth:`DesignProblem.objective_and_gradient`).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from pinid.model.base import BaseParameters, base_parameters
from pinid.memory import check_fits
from pinid.model.robot import RobotModel
from pinid.model.regressor import regressor, standard_parameters
from pinid.model.terms import columns as _term_columns
from pinid.model.terms import term_count as _term_count
from pinid.excitation.trajectory import FourierTrajectory
from pinid.excitation.spec import ExcitationSpec
from pinid.excitation.evaluation import clean_rest, sample_times

#: the criterion comes from the eigenvalues of the Gram matrix W_bᵀW_b (a fifth of the SVD's cost) while
#: cond(W_b) is below this: their relative round-off, about 1e-16·cond², is then below 1e-8; above it
#: (candidates far from any design) from the SVD of W_b
GRAM_COND = 1e4

#: ... and the base regressor has at least this many columns: below, its SVD costs less than the regressor
#: (0.1 ms for exo_leg's 400 × 10) and is kept, which leaves the small robots' designs as they were
GRAM_COLUMNS = 20


def _singular_values(Wb: np.ndarray) -> np.ndarray:
    """Singular values, descending, of a batch of base regressors ``Wb (P, rows, nb)`` → ``(P, nb)``: the
    square roots of the Gram matrices' eigenvalues, or the SVD where the condition number is above
    :data:`GRAM_COND` or it has fewer than :data:`GRAM_COLUMNS` columns."""
    if Wb.shape[-1] < GRAM_COLUMNS:
        return np.linalg.svd(Wb, compute_uv=False)
    lam = np.linalg.eigvalsh(np.swapaxes(Wb, 1, 2) @ Wb)[:, ::-1]
    sv = np.sqrt(np.clip(lam, 0.0, None))
    bad = ~(sv[:, -1] * GRAM_COND > sv[:, 0])
    if bad.any():
        sv[bad] = np.linalg.svd(Wb[bad], compute_uv=False)
    return sv


def _extreme_pairs(Wb: np.ndarray, sv: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """``[(u, v, σ)]`` of the largest and the smallest singular value of ``Wb (rows, nb)`` (``sv``: its
    singular values, descending): from the Gram matrix's eigenvectors (u = W_b v / σ) while the condition
    number is below :data:`GRAM_COND` (and W_b has :data:`GRAM_COLUMNS` columns or more), otherwise from the SVD."""
    if sv[-1] * GRAM_COND > sv[0] and Wb.shape[-1] >= GRAM_COLUMNS:
        lam, V = np.linalg.eigh(Wb.T @ Wb)
        out = []
        for i in (-1, 0):
            s = float(np.sqrt(lam[i]))
            out.append((Wb @ V[:, i] / s, V[:, i], s))
        return out
    U, s, Vt = np.linalg.svd(Wb, full_matrices=False)
    return [(U[:, 0], Vt[0], float(s[0])), (U[:, -1], Vt[-1], float(s[-1]))]


class DesignProblem:
    """The design variables, their map to Fourier coefficients, limits as linear constraints, and the
    criterion evaluated for a whole batch of candidates.

    Variables ``x``, per joint j in model order: the free coefficients ``z_j`` — ``[a_1..a_N, b_1..b_N]``,
    or without a_1 and b_1 when starting at rest — then the offsets q0 (one per joint) when
    ``optimize_offsets``.  Coefficients are ``c_j = T z_j`` (T eliminates a_1, b_1 for rest start).
    """

    def __init__(
        self,
        model: RobotModel,
        spec: ExcitationSpec,
        *,
        check_samples: int | None = None,
        base: BaseParameters | None = None,
    ) -> None:
        self.model, self.spec = model, spec
        self.base = base or base_parameters(model, spec.terms)
        spec.validate(model, self.base)
        self.nv, self.N, self.w = model.nv, int(spec.harmonics), float(spec.base_frequency)
        N = self.N
        k = np.arange(1, N + 1)
        # T: (2N, m) from free variables to [a_1..a_N, b_1..b_N]
        if spec.rest_start:
            m = 2 * (N - 1)
            T = np.zeros((2 * N, m))
            T[1:N, : N - 1] = np.eye(N - 1)
            T[N + 1 :, N - 1 :] = np.eye(N - 1)
            T[0, : N - 1] = -k[1:]  # a_1 = −Σ k a_k   (dq(0) = 0)
            T[N, N - 1 :] = -(k[1:] ** 2)  # b_1 = −Σ k² b_k  (ddq(0) = 0)
            self.harmonic_of = np.concatenate([k[1:], k[1:]])
        else:
            m = 2 * N
            T = np.eye(2 * N)
            self.harmonic_of = np.concatenate([k, k])
        self.T, self.m = T, m
        self.d = self.nv * m + (self.nv if spec.optimize_offsets else 0)
        # The regressor of every sample and its derivatives along the d variables: about 17 kB per
        # sample for exo_leg (8 bytes · nv · p · (2d + 20); measured, docs/benchmarks.md "Memory").
        per_sample = 8.0 * self.nv * len(self.base.standard_names) * (2 * self.d + 20)
        check_fits(
            per_sample * spec.samples,
            f"samples={spec.samples} (--samples, or samples in the spec)",
            per_item=per_sample,
        )
        self.times = sample_times(spec.period, spec.samples)
        self.check_times = sample_times(spec.period, check_samples or max(2 * spec.samples, 40 * N))
        self._basis_design, self._basis_check = self._basis_at(self.times), self._basis_at(self.check_times)
        self.theta = standard_parameters(model, spec.terms) if spec.has_torque_limits else None
        self.nfev = 0  # criterion values computed (a value with its gradient counts once)
        self.regressor_samples = 0  # samples whose regressor was computed: the cost of the design

    # ------------------------------------------------------------------ variables
    def _basis_at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Matrices (n, m) from free variables z_j to q − q0, dq, ddq at times t."""
        kw = np.arange(1, self.N + 1) * self.w
        s, c = np.sin(np.outer(t, kw)), np.cos(np.outer(t, kw))
        Bq = np.hstack([s, c]) @ self.T
        Bdq = np.hstack([c * kw, -s * kw]) @ self.T
        Bddq = np.hstack([-s * kw**2, -c * kw**2]) @ self.T
        return Bq, Bdq, Bddq

    def split(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(Z (P, nv, m), q0 (P, nv))`` of a batch of variables ``X (P, d)``."""
        X = np.atleast_2d(X)
        Z = X[:, : self.nv * self.m].reshape(len(X), self.nv, self.m)
        q0 = (
            X[:, self.nv * self.m :] if self.spec.optimize_offsets else np.broadcast_to(self.spec.q0, (len(X), self.nv))
        )
        return Z, q0

    def join(self, Z: np.ndarray, q0: np.ndarray | None = None) -> np.ndarray:
        """Inverse of :meth:`split`."""
        X = Z.reshape(len(Z), -1)
        return np.hstack([X, q0]) if self.spec.optimize_offsets else X

    def trajectory(self, x: np.ndarray, meta: dict | None = None) -> FourierTrajectory:
        """The Fourier trajectory of variables ``x (d,)``."""
        Z, q0 = self.split(np.asarray(x, float)[None, :])
        C = Z[0] @ self.T.T  # (nv, 2N)
        return FourierTrajectory(
            self.model.joint_names, self.w, q0[0].copy(), C[:, : self.N], C[:, self.N :], meta=dict(meta or {})
        )

    def variables(self, trajectory: FourierTrajectory) -> np.ndarray:
        """Variables ``x`` of a trajectory of this problem's form (least squares if it is not exactly of it)."""
        C = np.hstack([trajectory.a, trajectory.b])  # (nv, 2N)
        Z = np.linalg.lstsq(self.T, C.T, rcond=None)[0].T
        return self.join(Z[None], trajectory.q0[None, :])[0]

    def _basis_for(self, t: np.ndarray | None):
        if t is None or t is self.times:
            return self._basis_design
        if t is self.check_times:
            return self._basis_check
        return self._basis_at(t)

    def states(self, X: np.ndarray, t: np.ndarray | None = None):
        """q, dq, ddq ``(P, n, nv)`` of a batch at the design samples (default) or at times ``t``."""
        Bq, Bdq, Bddq = self._basis_for(t)
        Z, q0 = self.split(X)
        q = np.einsum("nm,pjm->pnj", Bq, Z) + q0[:, None, :]
        return q, np.einsum("nm,pjm->pnj", Bdq, Z), np.einsum("nm,pjm->pnj", Bddq, Z)

    # ------------------------------------------------------------------ bounds and limits
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the variables for the metaheuristics: each coefficient of harmonic k at most the largest
        amplitude that harmonic could have alone (position room, dq_max/(kω), ddq_max/(kω)²); offsets in range."""
        s = self.spec
        room = np.minimum(s.q0 - s.lower, s.upper - s.q0)
        if s.optimize_offsets:
            room = 0.5 * (s.upper - s.lower)
        kw = self.harmonic_of * self.w
        B = np.minimum.reduce(
            [
                np.broadcast_to(room[:, None], (self.nv, self.m)),
                s.velocity[:, None] / kw[None, :],
                s.acceleration[:, None] / kw[None, :] ** 2,
            ]
        )
        upper = B.reshape(-1)
        lower = -upper
        if s.optimize_offsets:
            lower = np.concatenate([lower, s.lower])
            upper = np.concatenate([upper, s.upper])
        return lower, upper

    def linear_constraints(self) -> tuple[np.ndarray, np.ndarray]:
        """``A x <= b``: position, velocity and acceleration limits of every joint on the check grid (computed
        once; do not modify them)."""
        if getattr(self, "_linear", None) is not None:
            return self._linear
        s = self.spec
        Bq, Bdq, Bddq = self._basis_check
        n = len(self.check_times)
        rows, rhs = [], []
        for j in range(self.nv):
            block = np.zeros((6 * n, self.d))
            cols = slice(j * self.m, (j + 1) * self.m)
            block[0 * n : 1 * n, cols], block[1 * n : 2 * n, cols] = Bq, -Bq
            block[2 * n : 3 * n, cols], block[3 * n : 4 * n, cols] = Bdq, -Bdq
            block[4 * n : 5 * n, cols], block[5 * n : 6 * n, cols] = Bddq, -Bddq
            if s.optimize_offsets:
                q0col = self.nv * self.m + j
                block[0:n, q0col], block[n : 2 * n, q0col] = 1.0, -1.0
                b_pos = np.concatenate([np.full(n, s.upper[j]), np.full(n, -s.lower[j])])
            else:
                b_pos = np.concatenate([np.full(n, s.upper[j] - s.q0[j]), np.full(n, s.q0[j] - s.lower[j])])
            rows.append(block)
            rhs.append(np.concatenate([b_pos, np.full(2 * n, s.velocity[j]), np.full(2 * n, s.acceleration[j])]))
        self._linear = np.vstack(rows), np.concatenate(rhs)
        return self._linear

    def scale_into_limits(self, X: np.ndarray, t: np.ndarray | None = None, safety: float = 0.0) -> np.ndarray:
        """Scale each joint's coefficients of every candidate by the largest factor ≤ 1 that puts its
        position, velocity and acceleration inside the limits on grid ``t`` (default: the check grid)
        — the parametrisation that makes every metaheuristic candidate feasible.  Offsets are clipped into
        their range first.  ``safety`` shrinks the factor by that fraction (for a margin between grid points)."""
        s = self.spec
        X = np.array(np.atleast_2d(X), dtype=float)
        if s.optimize_offsets:
            X[:, self.nv * self.m :] = np.clip(X[:, self.nv * self.m :], s.lower, s.upper)
        q, dq, ddq = self.states(X, self.check_times if t is None else t)
        Z, q0 = self.split(X)
        dev = q - q0[:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            up = np.where(dev > 0, (s.upper - q0)[:, None, :] / dev, np.inf).min(axis=1)
            down = np.where(dev < 0, (s.lower - q0)[:, None, :] / dev, np.inf).min(axis=1)
            v = s.velocity / np.abs(dq).max(axis=1)
            a = s.acceleration / np.abs(ddq).max(axis=1)
        factor = np.minimum.reduce([np.ones_like(up), up, down, v, a]) * (1 - safety)
        factor = np.clip(np.nan_to_num(factor, nan=1.0, posinf=1.0), 0.0, 1.0)
        return self.join(Z * factor[:, :, None], q0)

    # ------------------------------------------------------------------ criterion
    def _regressors(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Full stacked regressors ``(P·n·nv, p)`` and base regressors ``(P, n·nv, nb)`` of a batch."""
        P, n, nv = len(X), len(self.times), self.nv
        q, dq, ddq = self.states(X)
        W = self._stacked(q.reshape(-1, nv), clean_rest(dq.reshape(-1, nv)), ddq.reshape(-1, nv))
        self.nfev += P
        self.regressor_samples += P * n
        return W, W[:, self.base.independent].reshape(P, n * nv, -1)

    def _stacked(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
        """The stacked regressor ``(N·nv, p)`` of the motion ``(N, nv)``: what :func:`regressor` returns, without
        its argument checks and with one Pinocchio data kept (the states come from this problem, of the right
        shape; 5–10 % of a design's time on exo_leg went to those checks)."""
        model, n, nv = self.model, len(q), self.nv
        ni = 10 * nv
        nt = self._n_terms if getattr(self, "_n_terms", None) is not None else _term_count(model, self.spec.terms)
        self._n_terms = nt
        out = np.empty((n, nv, ni + nt))
        inertial = out[:, :, :ni]
        m = model.pin_model
        if getattr(self, "_pin_data", None) is None:
            self._pin_data = m.createData()
        d, compute = self._pin_data, pin.computeJointTorqueRegressor
        if model.continuous:
            conf = model.configuration
            for k in range(n):
                inertial[k] = compute(m, d, conf(q[k]), dq[k], ddq[k])
        else:
            for k in range(n):
                inertial[k] = compute(m, d, q[k], dq[k], ddq[k])
        if nt:
            out[:, :, ni:] = 0.0
            _term_columns(model, self.spec.terms, q, dq, ddq, out=out[:, :, ni:])
        return out.reshape(n * nv, ni + nt)

    def evaluate(self, X: np.ndarray, *, torque: bool = False):
        """Criterion values ``(P,)`` of a batch (``cond``: condition number; ``logdet``: −log det(WᵀW));
        with ``torque``, also the nominal torques ``(P, samples, nv)`` at the design samples."""
        X = np.atleast_2d(X)
        W, Wb = self._regressors(X)
        with np.errstate(divide="ignore", invalid="ignore"):
            sv = _singular_values(Wb)
            if self.spec.criterion == "cond":
                values = np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
            else:
                values = np.where(sv[:, -1] > 0, -2 * np.sum(np.log(sv), axis=1), np.inf)
        if torque:
            return values, (W @ self.theta).reshape(len(X), len(self.times), self.nv)
        return values

    def objective(self, x: np.ndarray, *, torque: bool = False) -> tuple[float, np.ndarray | None]:
        """``(f, tau)`` at ``x``: the value of :meth:`objective_and_gradient` without its gradient (what a
        line search asks for; about a fifth of the cost), and with ``torque`` the nominal torques
        ``(samples, nv)``.  The regressor and its SVD are kept, so a gradient at the same ``x`` next reuses them."""
        state = self._value_state(x)
        tau = (state["W0"] @ self.theta).reshape(len(self.times), self.nv) if torque else None
        return state["f"], tau

    def _value_state(self, x: np.ndarray) -> dict:
        """The regressor at the samples, its base columns' SVD and the criterion value at ``x`` (the last
        one is kept: SLSQP asks for the gradient at the point whose value it just accepted)."""
        x = np.asarray(x, dtype=float)
        key = x.tobytes()
        last = getattr(self, "_last", None)
        if last is not None and last["key"] == key:
            return last
        n = len(self.times)
        q, dq, ddq = (v[0] for v in self.states(x[None, :]))
        dq = clean_rest(dq)
        W0 = self._stacked(q, dq, ddq)
        self.regressor_samples += n
        self.nfev += 1
        Wb, pairs = W0[:, self.base.independent], None
        try:
            if Wb.shape[1] < GRAM_COLUMNS:  # a small regressor: its SVD, vectors included, as it is cheap
                U, sv, Vt = np.linalg.svd(Wb, full_matrices=False)
                pairs = [(U[:, 0], Vt[0], sv[0]), (U[:, -1], Vt[-1], sv[-1])]
            else:
                sv = _singular_values(Wb[None])[0]
        except np.linalg.LinAlgError:
            sv = np.zeros(1)
        if not sv[-1] > 0:
            f = np.inf
        elif self.spec.criterion == "cond":
            f = float(np.log(sv[0] / sv[-1]))
        else:
            f = float(-2 * np.sum(np.log(sv)))
        self._last = {"key": key, "q": q, "dq": dq, "ddq": ddq, "W0": W0, "Wb": Wb, "sv": sv, "f": f, "pairs": pairs}
        return self._last

    def objective_and_gradient(self, x: np.ndarray, h: float = 1e-7, *, torque: bool = False):
        """``(f, grad, tau, tau_jac)`` at ``x``.

        ``f``: log cond(W_b) (criterion ``cond``) or −log det(W_bᵀW_b) (``logdet``).  The gradient uses the
        singular vectors of W_b(x): ``dσ_i = u_iᵀ dW v_i``.  For ``cond`` it is exact: ``W·v`` is the
        inverse dynamics of a model whose inertial parameters are ``v`` (the regressor is linear in them),
        so ``d(W v)`` with respect to each sample's q, dq, ddq is Pinocchio's RNEA derivatives of that model
        (:meth:`_contract`) — three RNEA-derivative passes per sample, whatever the number of design
        variables.  For ``logdet`` it uses forward differences of step ``h`` of each sample's regressor row
        (exact for ddq).  Joint-term columns: analytic (Coulomb: 0 almost everywhere).  The chain rule
        through the Fourier basis gives d/dx.  With ``torque``: the nominal torques ``tau (samples, nv)``
        and their Jacobian ``tau_jac (samples·nv, d)`` (RNEA derivatives of the nominal model).  The value
        at the same ``x`` as the last :meth:`objective` is not computed again."""
        st = self._value_state(x)
        n, nv = len(self.times), self.nv
        q, dq, ddq, W0, Wb, sv, f = (st[k] for k in ("q", "dq", "ddq", "W0", "Wb", "sv", "f"))
        tau = tau_jac = None
        if not np.isfinite(f):
            G = np.zeros((3 * nv, n))
        else:
            cols = self.base.independent

            def full(v):  # a vector over the base columns, spread over all columns (zeros elsewhere)
                out = np.zeros(W0.shape[-1])
                out[cols] = v
                return out

            if self.spec.criterion == "cond":
                (u_max, v_max, s_max), (u_min, v_min, s_min) = st["pairs"] or _extreme_pairs(Wb, sv)
                G = self._contract(
                    q,
                    dq,
                    ddq,
                    [full(v_max), full(v_min)],
                    [u_max.reshape(n, nv) / s_max, -u_min.reshape(n, nv) / s_min],
                )
            else:
                U, sv, Vt = np.linalg.svd(Wb, full_matrices=False)
                D = self._difference_derivatives(q, dq, ddq, h, W0)
                pinv_t = np.zeros((n * nv, D.shape[-1]))
                pinv_t[:, cols] = (U / sv) @ Vt  # (W_b⁺)ᵀ: d log det(W_bᵀW_b) = 2 <(W_b⁺)ᵀ, dW_b>
                G = -2 * (D.reshape(len(D), n, -1) * pinv_t.reshape(n, -1)).sum(-1)
        grad = self._chain(G)
        if torque:
            tau = (W0 @ self.theta).reshape(n, nv)
            ni = 10 * nv
            dtau = np.moveaxis(self._rnea_derivatives(self.model.pin_model, q, dq, ddq), 3, 1)  # (3, nv, n, nv)
            dtau = dtau.reshape(3 * nv, n, nv) + (self._term_derivatives() @ self.theta[ni:])[:, None, :]
            tau_jac = self._chain_rows(dtau)
        return f, grad, tau, tau_jac

    def _difference_derivatives(self, q, dq, ddq, h, W0):
        """``D (3nv, n, nv, p)``: d(row of sample s)/d(q_j, dq_j, ddq_j) by forward differences of step ``h``
        from the regressor ``W0 (n·nv, p)`` at the samples (rigid-body columns), analytic for the term columns."""
        n, nv = len(q), self.nv
        k = 3 * nv
        Q, DQ, DDQ = (np.broadcast_to(v, (k, n, nv)).copy() for v in (q, dq, ddq))
        for j in range(nv):
            Q[j, :, j] += h
            DQ[nv + j, :, j] += h
            DDQ[2 * nv + j, :, j] += h
        W = regressor(self.model, Q.reshape(-1, nv), DQ.reshape(-1, nv), DDQ.reshape(-1, nv), self.spec.terms)
        self.regressor_samples += k * n
        D = (W.reshape(k, n, nv, -1) - W0.reshape(n, nv, -1)) / h
        ni = 10 * nv
        D[:, :, :, ni:] = self._term_derivatives()[:, None, :, :]
        return D

    def _term_derivatives(self) -> np.ndarray:
        """``(3nv, nv, nt)``: d(term column of joint row i)/d(q_j, dq_j, ddq_j), the same at every sample:
        1 for viscous friction (dq) and armature (ddq), G[m, i]·G[m, k] for their motor forms, 0 otherwise
        (Coulomb: 0 almost everywhere)."""
        if getattr(self, "_term_d", None) is not None:
            return self._term_d
        nv, terms = self.nv, self.spec.terms
        nt = len(terms.joint)
        D = np.zeros((3 * nv, nv, _term_count(self.model, terms)))
        for t, term in enumerate(terms.joint):
            for j in range(nv):
                col = j * nt + t
                if term.name == "fv":
                    D[nv + j, j, col] = 1.0
                elif term.name == "armature":
                    D[2 * nv + j, j, col] = 1.0
        if terms.motor:  # column G[m, j]·(G·dq)_m: derivative G[m, j]·G[m, k] with respect to dq_k (ddq_k)
            G, ntm = self.model.drives.matrix, len(terms.motor)
            for t, term in enumerate(terms.motor):
                if term.suffix not in ("fv", "armature"):
                    continue
                block = nv if term.suffix == "fv" else 2 * nv
                for m in range(G.shape[0]):
                    D[block : block + nv, :, nt * nv + m * ntm + t] = np.outer(G[m], G[m])
        self._term_d = D
        return D

    def _rnea_derivatives(self, pin_model, q, dq, ddq) -> np.ndarray:
        """``(3, n, nv, nv)``: ∂τ/∂q, ∂τ/∂dq, ∂τ/∂ddq of the Pinocchio model ``pin_model`` at each sample
        (``[k, s, i, j]`` = ∂τ_i/∂state_j at sample s)."""
        n, nv = q.shape
        out = np.empty((3, n, nv, nv))
        data = pin_model.createData()
        rnea_d = pin.computeRNEADerivatives
        conf = self.model.configuration if self.model.continuous else None
        for s in range(n):
            a, b, c = rnea_d(pin_model, data, conf(q[s]) if conf else q[s], dq[s], ddq[s])
            out[0, s], out[1, s], out[2, s] = a, b, c
        M = out[2]  # Pinocchio fills the upper triangle of the mass matrix only
        low = self._lower_triangle()
        M[:, low[0], low[1]] = M[:, low[1], low[0]]
        self.regressor_samples += n
        return out

    def _lower_triangle(self) -> tuple[np.ndarray, np.ndarray]:
        if getattr(self, "_tril", None) is None:
            self._tril = np.tril_indices(self.nv, -1)
        return self._tril

    def _contract(self, q, dq, ddq, vectors: list[np.ndarray], weights: list[np.ndarray]) -> np.ndarray:
        """``G (3nv, n)`` = Σ_r Σ_i weights[r][s, i]·d(W(s) vectors[r])_i/d(state_j(s)), exactly.

        ``W v`` restricted to the inertial columns is the inverse dynamics of a model whose inertial
        parameters are ``v``; a parameter vector need not be a physical body (its mass can be 0), so every
        body gets a shift ``c·e`` (mass c at the joint, inertia c·1, c > 2 max|v|) and the shift's own
        derivatives (one more pass) are subtracted — RNEA is linear in the inertial parameters."""
        nv, ni = self.nv, 10 * self.nv
        e = np.tile([1.0, 0, 0, 0, 1, 0, 1, 0, 0, 1], nv)
        c = 1.0 + 2.0 * max(np.abs(v[:ni]).max() for v in vectors)
        pm = self._scratch_model()
        Dt = self._term_derivatives()
        G = np.zeros((3 * nv, len(q)))
        shift_weight = 0.0
        for v, u in zip(vectors, weights):
            self._set_inertias(pm, v[:ni] + c * e)
            R = self._rnea_derivatives(pm, q, dq, ddq)
            G += np.einsum("ksij,si->kjs", R, u).reshape(3 * nv, -1)
            G += (Dt @ v[ni:]) @ u.T
            shift_weight = shift_weight + u
        self._set_inertias(pm, c * e)
        R = self._rnea_derivatives(pm, q, dq, ddq)
        G -= np.einsum("ksij,si->kjs", R, shift_weight).reshape(3 * nv, -1)
        return G

    def _scratch_model(self):
        if getattr(self, "_scratch", None) is None:
            self._scratch = pin.Model(self.model.pin_model)
        return self._scratch

    def _set_inertias(self, pin_model, theta: np.ndarray) -> None:
        for i in range(self.nv):
            pin_model.inertias[i + 1] = pin.Inertia.FromDynamicParameters(theta[10 * i : 10 * i + 10])

    def _chain(self, G: np.ndarray) -> np.ndarray:
        """d/dx of Σ_s G[type_j, s]·d(state_j(s)): G is (3nv, n) per (q_j, dq_j, ddq_j) and sample."""
        Bq, Bdq, Bddq = self._basis_design
        nv = self.nv
        grad = np.concatenate([Bq.T @ G[j] + Bdq.T @ G[nv + j] + Bddq.T @ G[2 * nv + j] for j in range(nv)])
        if self.spec.optimize_offsets:
            grad = np.concatenate([grad, G[:nv].sum(axis=1)])
        return grad

    def _chain_rows(self, dtau: np.ndarray) -> np.ndarray:
        """Jacobian ``(n·nv, d)`` of per-sample outputs whose state derivatives are ``dtau (3nv, n, nv)``."""
        Bq, Bdq, Bddq = self._basis_design
        n, nv, m = len(self.times), self.nv, self.m
        J = np.zeros((n, nv, self.d))
        for j in range(nv):
            cols = slice(j * m, (j + 1) * m)
            J[:, :, cols] = (
                dtau[j][:, :, None] * Bq[:, None, :]
                + dtau[nv + j][:, :, None] * Bdq[:, None, :]
                + dtau[2 * nv + j][:, :, None] * Bddq[:, None, :]
            )
            if self.spec.optimize_offsets:
                J[:, :, nv * m + j] = dtau[j]
        return J.reshape(n * nv, self.d)

    def torque_violation(self, tau: np.ndarray) -> np.ndarray:
        """Worst relative torque excess per candidate (0 when within the limits)."""
        limit = self.spec.torque
        excess = (np.abs(tau) - limit) / np.where(np.isfinite(limit), limit, 1.0)
        excess = np.where(np.isfinite(limit), excess, -np.inf)
        return np.maximum(excess.max(axis=(1, 2)), 0.0)
