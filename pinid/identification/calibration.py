"""Sensor calibration of a floating-base recording, identified with the inertial parameters (issue 46).

The terms (:mod:`pinid.model.calibration`: a sensor's offsets held by its swing phases, gravity's direction in
the motion-capture world) correct the prepared training recordings before their rows are stacked, and the
validation recordings with the same values.  This module finds their values and chooses which enter:

* **held** terms are estimated from the recordings alone (:attr:`~pinid.model.calibration.CalibrationTerm.held`);
* **fitted** terms turn gravity in the base frame.  The rows depend on gravity's base-frame vector ``g_B`` linearly
  (gravity acts as an acceleration ``−g_B`` of the whole robot), so with ``A_k`` the rows' regressor for a unit
  linear acceleration of the base along its axis ``k`` (no velocity, no joint motion, gravity taken out),
  ``W(φ) = W(φ₀) − Σ_k (g_B,k(φ) − g_B,k(φ₀))·A_k``: one regressor build at ``φ₀`` and three for ``A`` serve every
  ``φ``.  Gauss-Newton on the inertial base parameters θ and the angles φ together (weighted least squares, the
  rows' own weights) converges in a few steps; σ of φ (and θ) is the Newey–West sandwich of the joint problem
  (:mod:`pinid.problem.covariance`), so it counts the angles' correlation with the inertia.
* **Which terms enter** (``calibration="auto"``, the default): forward selection by blocked cross-validation on the
  training recordings only (:mod:`pinid.identification.crossval`: 5 contiguous blocks per recording, least squares
  on four, the fifth scored against the wrench and torque as recorded): a term enters when it lowers the held-out
  error by more than two standard errors of the paired fold-by-fold difference.  A candidate whose total mass
  (least squares on all training rows) leaves :data:`MASS_BAND` × the URDF's is refused, with a warning: a model
  class that predicts better by becoming unphysical is not a result.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg

from pinid.errors import SpecError
from pinid.identification.crossval import FOLDS, better, fold_scores
from pinid.model.calibration import CALIBRATION_TERMS, Estimate, calibration_names, calibration_term
from pinid.problem.covariance import hac_covariance

#: A calibration whose total mass leaves this band × the URDF's is refused (auto) or warned (given).
MASS_BAND = (0.8, 1.25)
#: ``auto``: a term is a candidate only when one of its values differs from zero by more than this many σ.
SIGNIFICANT = 3.0
#: Gauss-Newton: at most this many steps; done when the angles move less than ``GN_TOL`` [rad].
GN_STEPS, GN_TOL = 30, 1e-7
#: ``auto`` fits its candidates from precomputed Gram blocks (:class:`_Gram`); False: on the rows themselves (the
#: reference the tests compare it with).
GRAM = True


@dataclass
class Calibration:
    """The calibration applied: ``terms`` in order, each one's :class:`~pinid.model.calibration.Estimate`
    (values with σ), how they were chosen (``steps``: each forward-selection step's candidates and their
    held-out relative RMS [%]) and the total mass [kg] of the least-squares fit with each candidate."""

    terms: list[str] = field(default_factory=list)
    estimates: dict[str, Estimate] = field(default_factory=dict)
    steps: list[dict[str, float]] = field(default_factory=list)
    chosen_by: str = "given"
    masses: dict[str, float] = field(default_factory=dict)
    refused: list[str] = field(default_factory=list)

    def apply(self, samples: Sequence) -> list:
        """The prepared recordings with every term's correction (held terms first, in registry order)."""
        out = list(samples)
        for name in self.terms:
            term = calibration_term(name)
            out = [term.apply(s, self.estimates[name]) for s in out]
        return out

    def to_dict(self) -> dict:
        """Plain-JSON form (``identification.json``'s ``data.calibration``): per term its values and σ by name,
        shown in their reported units (angles in degrees)."""
        terms = {}
        for name in self.terms:
            e, term = self.estimates[name], calibration_term(name)
            shown = term.shown or (lambda v: v)
            units = term.shown_units(None) if term.shown_units else e.units
            terms[name] = {
                "label": term.label,
                "values": {n: float(v) for n, v in zip(e.names, shown(np.asarray(e.values)))},
                "std": {
                    n: (None if not np.isfinite(s) else float(s)) for n, s in zip(e.names, shown(np.asarray(e.std)))
                },
                "units": dict(zip(e.names, units)),
                "info": e.info,
            }
        return {
            "terms": list(self.terms),
            "chosen_by": self.chosen_by,
            "steps": [{k: (None if not np.isfinite(v) else float(v)) for k, v in s.items()} for s in self.steps],
            "total_mass_ols": {k: float(v) for k, v in self.masses.items()},
            "refused": list(self.refused),
            **terms,
        }

    def text(self) -> str:
        """One line per term: the values with their σ."""
        if not self.terms:
            head = "calibration: none"
            if self.steps:
                head += (
                    f" (chosen by {self.chosen_by}: "
                    + ", ".join(f"{k} {v:.3g} %" for s in self.steps for k, v in s.items())
                    + ")"
                )
            return head
        lines = [f"calibration: {', '.join(self.terms)} ({self.chosen_by})"]
        for name, d in ((n, self.to_dict()[n]) for n in self.terms):
            vals = ", ".join(
                f"{k.removeprefix('gravity.')} {v:.4g} ± {d['std'][k] if d['std'][k] is not None else float('nan'):.2g} {d['units'][k]}"
                for k, v in d["values"].items()
            )
            lines.append(f"  {name}: {vals}")
        if self.steps:
            lines.append(
                "  held-out rel. RMS per step: "
                + " → ".join(f"{min(s, key=s.get)} {min(s.values()):.3g} %" for s in self.steps)
            )
        return "\n".join(lines)


def total_mass_vector(base) -> np.ndarray | None:
    """``c`` with ``c · β = Σ mᵢ`` for every standard θ (β = P·θ the base parameters), or None when the rows do not
    determine the total mass."""
    mass = np.array([n.rsplit(".", 1)[-1] == "m" for n in base.standard_names], dtype=float)
    c, *_ = np.linalg.lstsq(base.P.T, mass, rcond=None)
    if np.max(np.abs(base.P.T @ c - mass)) > 1e-8:
        return None
    return c


def urdf_mass(model) -> float:
    return float(sum(i.mass for i in model.ff_model.inertias))


# --------------------------------------------------------------------------------------------------- the rows
class _Rows:
    """The stacked rows of prepared recordings (held terms applied) with what turns gravity (module text)."""

    def __init__(self, model, samples, *, terms, base, rows, base_weight, rest_velocity, gravity: bool) -> None:
        from pinid.model.floating import row_mask
        from pinid.problem.floating import FloatingRows, floating_targets, swing_rows

        # the rows as floating_problem stacks them, without its excitation check: a periodic gait leaves some
        # base parameters of the base rows undetermined (their Gram is then solved by pseudo-inverse)
        mask = row_mask(model.nv, rows)
        self.model, self.base, self.samples = model, base, list(samples)
        self.keeps = [swing_rows(model, s, mask) for s in samples]
        self.W0 = FloatingRows(model, terms, base, self.samples, self.keeps).build()
        self.y = np.concatenate([floating_targets(model, s)[k] for s, k in zip(samples, self.keeps)])
        self.w = np.full(len(self.y), float(base_weight))
        offsets = np.cumsum([0, *[s.n for s in samples]])
        self.sample = np.concatenate(
            [o + np.broadcast_to(np.arange(s.n)[:, None], k.shape)[k] for o, s, k in zip(offsets, samples, self.keeps)]
        )
        self.base_q = np.concatenate([s.base_q for s in samples])
        self.times = np.concatenate([s.data.t for s in samples])
        self.recording = np.concatenate([np.full(s.n, i) for i, s in enumerate(samples)])
        self.sizes = [s.n for s in samples]
        self._targets = floating_targets
        self.A = None
        if gravity:
            from scipy.spatial.transform import Rotation

            self.A = _unit_accelerations(model, samples, self.keeps, base)
        if gravity and self.A is None:
            # unit linear acceleration of the base along x, y, z, gravity cancelled: the rows see the base's
            # acceleration minus gravity (both in the base frame), so a = e_k + g_B gives A_k in one build each
            g = np.asarray(model.ff_model.gravity.linear, dtype=float)
            self.A = []
            for k in range(3):
                mod = []
                for s in samples:
                    a = np.zeros((s.n, 6))
                    a[:, :3] = Rotation.from_quat(s.base_q[:, 3:]).inv().apply(g)
                    a[:, k] += 1.0
                    z = np.zeros_like(s.data.q)
                    mod.append(replace(s, base_v=np.zeros((s.n, 6)), base_a=a, data=replace(s.data, dq=z, ddq=z)))
                self.A.append(FloatingRows(model, terms, base, mod, self.keeps).build())
        self._held_targets: dict[tuple, np.ndarray] = {}

    def targets(self, samples) -> np.ndarray:
        """The right-hand side of these rows for other (corrected) samples of the same recordings."""
        return np.concatenate([self._targets(self.model, s)[k] for s, k in zip(samples, self.keeps)])


def _unit_accelerations(model, samples, keeps, base) -> list[np.ndarray] | None:
    """``A_k`` of :class:`_Rows` (the base rows' regressor for a unit linear acceleration of the base along its axis
    ``k``, no velocity, no joint motion, no gravity) from the bodies' placements alone: every body then accelerates
    by ``a``, so body i's columns are ``m: [a; p_i × a]`` and ``h_j: [0; (R_i e_j) × a]`` (``R_i``, ``p_i`` its joint
    frame in the base frame; the inertia's columns are zero).  None when the rows are not the base rows of the
    inertial columns alone (the regressor builds them then)."""
    import pinocchio as pin

    from pinid.model.floating import BASE_NQ

    m, d = model.ff_model, model.ff_model.createData()
    nb = m.njoints - 1
    if len(base.standard_names) != 10 * nb or any(k[:, 6:].any() for k in keeps):
        return None
    blocks = [[], [], []]
    for s, keep in zip(samples, keeps):
        Q = np.zeros((s.n, m.nq))
        Q[:, 6] = 1.0  # the base at the origin: placements in the base frame
        Q[:, BASE_NQ:] = model.full_state(s.base_q, s.base_v, s.base_a, s.data.q, s.data.q * 0, s.data.q * 0)[0][
            :, BASE_NQ:
        ]
        Rs, ps = np.empty((s.n, nb, 3, 3)), np.empty((s.n, nb, 3))
        for k in range(s.n):
            pin.forwardKinematics(m, d, Q[k])
            for i in range(nb):
                Rs[k, i], ps[k, i] = d.oMi[i + 1].rotation, d.oMi[i + 1].translation
        for ax in range(3):
            e = np.zeros(3)
            e[ax] = 1.0
            Y = np.zeros((s.n, 6, nb, 10))
            Y[:, ax, :, 0] = 1.0
            Y[:, 3:, :, 0] = np.moveaxis(np.cross(ps, e), -1, 1)
            for j in range(3):
                Y[:, 3:, :, 1 + j] = np.moveaxis(np.cross(Rs[:, :, :, j], e), -1, 1)
            Y = Y.reshape(s.n, 6, 10 * nb)[:, :, base.independent]
            blocks[ax].append(Y[keep[:, :6]])
    return [np.concatenate(b) for b in blocks]


def _lstsq(W: np.ndarray, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted least squares by the normal equations of the column-scaled rows (Cholesky; a rank-deficient
    Gram falls back to the pseudo-inverse)."""
    Ww = W * w[:, None]
    return _solve_gram(W.T @ Ww, Ww.T @ y)


def _solve_gram(G: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The least squares of :func:`_lstsq` from its normal equations ``G x = b``."""
    scale = np.sqrt(np.diag(G))
    scale[scale == 0] = 1.0
    Gs = G / np.outer(scale, scale)
    b = b / scale
    try:
        return scipy.linalg.cho_solve(scipy.linalg.cho_factor(Gs, check_finite=False), b, check_finite=False) / scale
    except np.linalg.LinAlgError:
        return np.linalg.pinv(Gs) @ b / scale


def _dgravity(term, phi: np.ndarray, base_q: np.ndarray, g: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """(N, 3, len(φ)) derivative of gravity in the base frame with respect to the angles (central differences of
    an analytic function: exact to ~1e-10)."""
    out = []
    for j in range(len(phi)):
        d = np.zeros(len(phi))
        d[j] = h
        out.append((term.gravity(phi + d, base_q, g) - term.gravity(phi - d, base_q, g)) / (2 * h))
    return np.stack(out, axis=-1)


def _weights_of(R: _Rows, pick: np.ndarray) -> np.ndarray:
    return np.where(pick, R.w, 0.0)


def _W(R: _Rows, term, phi: np.ndarray, gB0: np.ndarray, g: np.ndarray) -> np.ndarray:
    d = (term.gravity(phi, R.base_q, g) - gB0)[R.sample]
    W = R.W0.copy()
    for k in range(3):
        W -= d[:, k, None] * R.A[k]
    return W


def _jphi(R: _Rows, term, phi: np.ndarray, theta: np.ndarray, g: np.ndarray) -> np.ndarray:
    At = np.column_stack([R.A[k] @ theta for k in range(3)])
    return np.einsum("rk,rkj->rj", At, _dgravity(term, phi, R.base_q, g)[R.sample])


def _fit_gravity(R: _Rows, term, y: np.ndarray, pick: np.ndarray, phi0: np.ndarray, g: np.ndarray, start: np.ndarray):
    """Gauss-Newton on θ and φ together over the rows ``pick`` (module text); returns (θ, φ, W(φ) of all rows,
    J_φ of all rows)."""
    phi = np.array(start, dtype=float)
    gB0 = term.gravity(phi0, R.base_q, g)
    w = _weights_of(R, pick)
    W = _W(R, term, phi, gB0, g)
    theta = _lstsq(W, y, w)
    for _ in range(GN_STEPS):
        Jphi = _jphi(R, term, phi, theta, g)
        step = _lstsq(np.hstack([W, -Jphi]), y - W @ theta, w)
        theta, phi = theta + step[: W.shape[1]], phi + step[W.shape[1] :]
        W = _W(R, term, phi, gB0, g)
        if np.max(np.abs(step[W.shape[1] :])) < GN_TOL:
            break
    theta = _lstsq(W, y, w)
    return theta, phi, W, _jphi(R, term, phi, theta, g)


def _sigma(R: _Rows, W: np.ndarray, Jphi: np.ndarray, y: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Newey–West σ of (θ, φ) of the joint problem at its solution."""
    J = np.hstack([W, -Jphi])
    r = y - W @ theta
    sw = np.sqrt(R.w)
    scale = np.linalg.norm(J * sw[:, None], axis=0)
    scale[scale == 0] = 1.0
    Js = J / scale
    B = Js.T @ (Js * R.w[:, None])
    Binv = np.linalg.pinv(B)
    g = np.zeros((len(R.base_q), J.shape[1]))
    first = np.flatnonzero(np.r_[True, np.diff(R.sample) != 0])  # R.sample is sorted: sums of runs
    g[R.sample[first]] = np.add.reduceat(Js * (R.w * r)[:, None], first, axis=0)
    edges = np.cumsum([0, *R.sizes])
    dof = max(len(y) - J.shape[1], 1)
    cov, _ = hac_covariance(Binv, g, list(zip(edges[:-1], edges[1:])), len(y) / dof)
    return np.sqrt(np.clip(np.diag(cov), 0, None)) / scale


class _Gram:
    """The rows' Gram blocks, computed once, for every fit of the selection (issue 45: the calibration's cost).

    With ``g_B = R_MBᵀ·g_M(φ)`` (the term's ``world``), ``W(φ) = C − Σ_j g_M,j(φ)·B_j`` where ``C`` is the rows'
    regressor without gravity and ``B_j = Σ_k R_MB[j, k]·A_k`` (row by row): every ``W(φ)``, the Gauss-Newton
    Jacobian ``[W, −J_φ]`` and a held-out block's residual are ``X·T`` for ``X = [C, B_0, B_1, B_2]`` (only the
    columns gravity reaches in the ``B``) and a small ``T``.  So ``Xᵀ·X`` is summed once per *atom* (the rows held
    out by the same folds) and a fold's fit and score are those of ``Tᵀ·(Σ Xᵀ X)·T``: the same normal equations
    as :func:`_lstsq` on the rows themselves, equal to rounding, without touching the rows again.  Without a
    fitted term ``X = W₀``.  Only for uniform row weights (the base rows'), which the scores count unweighted."""

    def __init__(self, R: _Rows, term, g: np.ndarray, folds: int) -> None:
        self.term, self.g, self.folds = term, g, folds
        self.p = R.W0.shape[1]
        if term is None:
            X, self.nz = R.W0, np.zeros(0, int)
            self.phi0 = None
        else:
            from scipy.spatial.transform import Rotation

            self.phi0 = np.asarray(term.start(R.samples), dtype=float)
            gB0 = term.gravity(self.phi0, R.base_q, g)[R.sample]
            Rmb = Rotation.from_quat(R.base_q[:, 3:]).as_matrix()[R.sample]
            self.nz = np.flatnonzero(np.any([np.any(a != 0, axis=0) for a in R.A], axis=0))
            C = R.W0 + sum(gB0[:, k, None] * R.A[k] for k in range(3))
            B = [sum(Rmb[:, j, k, None] * R.A[k][:, self.nz] for k in range(3)) for j in range(3)]
            X = np.hstack([C, *B])
        t, rec = R.times[R.sample], R.recording[R.sample]
        edges = [np.linspace(s.data.t[0], s.data.t[-1], folds + 1) for s in R.samples]
        code = np.zeros(len(R.y), dtype=np.int64)
        for k in range(folds):
            held = np.zeros(len(R.y), bool)
            for i, e in enumerate(edges):
                held |= (rec == i) & (t >= e[k]) & (t <= e[k + 1])
            code |= held.astype(np.int64) << k
        self.order = np.argsort(code, kind="stable")
        self.codes, starts = np.unique(code[self.order], return_index=True)
        bounds = [*starts, len(code)]
        self.slices = [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]
        self.X = X[self.order]
        self.M = np.stack([self.X[sl].T @ self.X[sl] for sl in self.slices])
        self.counts = np.array([sl.stop - sl.start for sl in self.slices])
        self.y0 = self._sq(R.y)

    def _moments(self, y: np.ndarray) -> np.ndarray:
        ys = y[self.order]
        return np.stack([self.X[sl].T @ ys[sl] for sl in self.slices])

    def _sq(self, y: np.ndarray) -> np.ndarray:
        ys = y[self.order]
        return np.array([ys[sl] @ ys[sl] for sl in self.slices])

    def TW(self, phi) -> np.ndarray:
        """``T`` with ``W(φ) = X·T`` (``W₀`` without a fitted term)."""
        T = np.zeros((self.X.shape[1], self.p))
        T[: self.p] = np.eye(self.p)
        if phi is not None:
            gm, q = self.term.world(phi, self.g), len(self.nz)
            for j in range(3):
                T[self.p + j * q + np.arange(q), self.nz] = -gm[j]
        return T

    def TJ(self, phi, theta) -> np.ndarray:
        """``T`` with ``−J_φ = X·T`` at (φ, θ) (:func:`_jphi`)."""
        h, q = 1e-6, len(self.nz)
        dg = np.empty((3, len(phi)))
        for m in range(len(phi)):
            d = np.zeros(len(phi))
            d[m] = h
            dg[:, m] = (self.term.world(phi + d, self.g) - self.term.world(phi - d, self.g)) / (2 * h)
        T = np.zeros((self.X.shape[1], len(phi)))
        for j in range(3):
            T[self.p + j * q : self.p + (j + 1) * q] = -np.outer(theta[self.nz], dg[j])
        return T

    def fit(self, M: np.ndarray, b: np.ndarray, gravity: bool, start=None):
        """(θ, φ or None) of :func:`_fit` from the summed blocks ``M = Σ Xᵀ X``, ``b = Σ Xᵀ y``."""
        if not gravity:
            T = self.TW(None if self.term is None else self.phi0)
            return _solve_gram(T.T @ M @ T, T.T @ b), None
        phi = np.array(np.zeros(2) if start is None else start, dtype=float)
        TW = self.TW(phi)
        theta = _solve_gram(TW.T @ M @ TW, TW.T @ b)
        for _ in range(GN_STEPS):
            T = np.hstack([TW, self.TJ(phi, theta)])
            step = _solve_gram(T.T @ M @ T, T.T @ (b - M @ (TW @ theta)))
            theta, phi = theta + step[: self.p], phi + step[self.p :]
            TW = self.TW(phi)
            if np.max(np.abs(step[self.p :])) < GN_TOL:
                break
        return _solve_gram(TW.T @ M @ TW, TW.T @ b), phi

    def full(self, y: np.ndarray, gravity: bool, start=None):
        """(θ, φ) on every row."""
        return self.fit(self.M.sum(axis=0), self._moments(y).sum(axis=0), gravity, start)

    def fold_sums(self, y: np.ndarray, gravity: bool, start) -> np.ndarray:
        """:func:`_fold_sums` from the blocks."""
        v, yy = self._moments(y), self._sq(y)
        out = np.full((self.folds, 2), np.nan)
        for k in range(self.folds):
            held = ((self.codes >> k) & 1).astype(bool)
            if self.counts[~held].sum() <= self.p + 2:
                continue
            theta, phi = self.fit(self.M[~held].sum(axis=0), v[~held].sum(axis=0), gravity, start)
            x = self.TW(phi if gravity else (None if self.term is None else self.phi0)) @ theta
            Mh, bh = self.M[held].sum(axis=0), v[held].sum(axis=0)
            out[k] = float(yy[held].sum() - 2 * x @ bh + x @ Mh @ x), float(self.y0[held].sum())
        return out


#: The calibration is found on at most this many samples per recording (every k-th: a 1 kHz recording filtered at
#: 10 Hz repeats itself from sample to sample; σ is Newey–West's, which counts what is left of that).
MAX_SAMPLES = 10000


def _every(s, k: int):
    """Every ``k``-th sample of prepared floating recording ``s``."""
    if k <= 1:
        return s
    from pinid.model.floating import Wrench

    d = s.data
    data = replace(
        d,
        t=d.t[::k],
        q=d.q[::k],
        dq=None if d.dq is None else d.dq[::k],
        ddq=None if d.ddq is None else d.ddq[::k],
        tau=None if d.tau is None else d.tau[::k],
        floating=None,
    )
    return replace(
        s,
        data=data,
        base_q=s.base_q[::k],
        base_v=s.base_v[::k],
        base_a=s.base_a[::k],
        wrenches=[Wrench(w.link, w.values[::k], w.frame) for w in s.wrenches],
        unsensed={k_: v[::k] for k_, v in s.unsensed.items()},
        uncertain={k_: v[::k] for k_, v in s.uncertain.items()},
    )


# ------------------------------------------------------------------------------------------- fit and choose
@dataclass
class _Candidate:
    names: list[str]
    held: dict[str, Estimate]
    y: np.ndarray
    gravity_term: object = None


def _candidate(R: _Rows, names: list[str], held_all: dict[str, Estimate], samples) -> _Candidate:
    held = {n: held_all[n] for n in names if n in held_all}
    corrected = list(samples)
    for n in held if tuple(held) not in R._held_targets else ():
        corrected = [calibration_term(n).apply(s, held[n]) for s in corrected]
    key = tuple(held)
    if held and key not in R._held_targets:  # the same held terms give the same targets: computed once
        R._held_targets[key] = R.targets(corrected)
    y = R._held_targets[key] if held else R.y
    fitted = [calibration_term(n) for n in names if not calibration_term(n).held]
    if len(fitted) > 1:
        raise SpecError(f"calibration: terms {', '.join(t.name for t in fitted)} both turn gravity; expected one")
    return _Candidate(names, held, y, fitted[0] if fitted else None)


def _fit(R: _Rows, c: _Candidate, pick: np.ndarray, g: np.ndarray, start=None, gram: _Gram | None = None):
    """(θ, φ or None, W, Jφ or None) of a candidate on the rows ``pick`` (with ``gram``: on every row, from the
    Gram blocks)."""
    if gram is not None and c.gravity_term is not None:
        term = c.gravity_term
        theta, phi = gram.full(c.y, True, start)
        W = _W(R, term, phi, term.gravity(term.start(R.samples), R.base_q, g), g)
        return theta, phi, W, _jphi(R, term, phi, theta, g)
    if c.gravity_term is None:
        if gram is not None:
            return gram.full(c.y, False)[0], None, R.W0, None
        return _lstsq(R.W0, c.y, _weights_of(R, pick)), None, R.W0, None
    term = c.gravity_term
    phi0 = np.zeros(2) if start is None else start
    return _fit_gravity(R, term, c.y, pick, term.start(R.samples), g, phi0)


def _fold_sums(R: _Rows, c: _Candidate, g: np.ndarray, folds: int, start, gram: _Gram | None = None) -> np.ndarray:
    if gram is not None:
        return gram.fold_sums(c.y, c.gravity_term is not None, start)
    out = np.full((folds, 2), np.nan)
    t = R.times[R.sample]
    rec = R.recording[R.sample]
    edges = [np.linspace(s.data.t[0], s.data.t[-1], folds + 1) for s in R.samples]
    for k in range(folds):
        held = np.zeros(len(R.y), bool)
        for i, e in enumerate(edges):
            held |= (rec == i) & (t >= e[k]) & (t <= e[k + 1])
        train = ~held & (R.w > 0)
        if np.count_nonzero(train) <= R.W0.shape[1] + 2:
            continue
        theta, _, W, _ = _fit(R, c, train, g, start)
        out[k] = float(np.sum((c.y[held] - W[held] @ theta) ** 2)), float(np.sum(R.y[held] ** 2))
    return out


def fit_calibration(
    model,
    samples: Sequence,
    spec="auto",
    *,
    motion_capture: bool = True,
    folds: int = FOLDS,
) -> Calibration:
    """The calibration of prepared training recordings ``samples`` (module text): ``spec`` ``"auto"`` (chosen by
    blocked cross-validation), ``"none"``, or the terms to apply (``"offsets,tilt"``); ``motion_capture``: the
    base orientation is the motion capture's (only then is the tilt a candidate of ``"auto"``).  Found on the 6
    base rows (the whole-body wrench: where the sensors and gravity's direction act; plain least squares in N and
    N·m), whatever rows the identification then uses."""
    from pinid.model.base import base_parameters
    from pinid.model.terms import TermSelection

    terms, rows, base_weight, rest_velocity = TermSelection.from_names("none"), "base", 1.0, None
    names = calibration_names(spec)
    samples = [_every(s, -(-s.n // MAX_SAMPLES)) for s in samples]
    auto = names == "auto"
    offered = [
        n
        for n in (CALIBRATION_TERMS if auto else names)
        if calibration_term(n).applies(samples) and (n != "tilt" or motion_capture or not auto)
    ]
    if not offered:
        return Calibration(chosen_by="given" if not auto else "no term applies")
    held_all = {}
    for n in offered:
        term = calibration_term(n)
        if term.held:
            est = term.estimate(model, samples)
            if len(est.names) == 0:  # no sensor with a swing phase: nothing holds the offsets
                if not auto:
                    warnings.warn(
                        f"calibration {n}: no sensor with {0.2:g} s of swing; expected swing phases that hold them",
                        stacklevel=3,
                    )
                continue
            held_all[n] = est
    offered = [n for n in offered if calibration_term(n).held is False or n in held_all]
    gravity = any(not calibration_term(n).held for n in offered)
    if not any(len(s.wrenches) for s in samples):  # no wrench in the base rows: nothing to calibrate
        return Calibration(chosen_by="given" if not auto else "no wrench in the base rows")
    base = base_parameters(model, terms, rows="base")
    R = _Rows(
        model,
        samples,
        terms=terms,
        base=base,
        rows=rows,
        base_weight=base_weight,
        rest_velocity=rest_velocity,
        gravity=gravity,
    )
    g = np.asarray(model.ff_model.gravity.linear, dtype=float)
    cmass = total_mass_vector(R.base)
    nominal_mass = urdf_mass(model)
    everything = R.w > 0
    fitted_terms = [calibration_term(n) for n in offered if not calibration_term(n).held]
    gram = None
    if (
        GRAM
        and auto
        and len(fitted_terms) <= 1
        and all(t.world is not None for t in fitted_terms)
        and np.all(R.w == R.w[0])
        and R.w[0] > 0
    ):
        gram = _Gram(R, fitted_terms[0] if fitted_terms else None, g, folds)

    def mass_of(theta) -> float:
        return float("nan") if cmass is None else float(cmass @ theta)

    fits: dict[str, tuple] = {}

    def full_fit(c: _Candidate):
        key = ",".join(c.names) or "none"
        if key not in fits:
            fits[key] = _fit(R, c, everything, g, gram=gram)
        return fits[key]

    def physical(c: _Candidate) -> bool:
        m = mass_of(full_fit(c)[0])
        return not np.isfinite(m) or MASS_BAND[0] <= m / nominal_mass <= MASS_BAND[1]

    masses, refused = {}, []
    if not auto:
        chosen = offered
        c = _candidate(R, chosen, held_all, samples)
        theta = full_fit(c)[0]
        masses[",".join(chosen) or "none"] = mass_of(theta)
        if not physical(c):
            warnings.warn(
                f"calibration {', '.join(chosen)}: total mass {mass_of(theta):.4g} kg (least squares) against the URDF's "
                f"{nominal_mass:.4g} kg: outside {MASS_BAND[0]:g}–{MASS_BAND[1]:g} ×, not physical",
                stacklevel=3,
            )
        steps, how = [], "given"
    else:
        for n in list(offered):  # a term whose values are all within SIGNIFICANT σ of zero: not a candidate
            if calibration_term(n).held:
                e = held_all[n]
            else:
                c = _candidate(R, [n], held_all, samples)
                theta, phi, W, Jphi = full_fit(c)
                e = Estimate([], phi, _sigma(R, W, Jphi, c.y, theta)[W.shape[1] :], [], {})
            size = np.abs(np.asarray(e.values))
            if not np.any((size > SIGNIFICANT * np.asarray(e.std)) & (size > calibration_term(n).negligible)):
                offered.remove(n)
        if not offered:
            return Calibration(chosen_by="no term differs from zero by 3 σ")
        chosen, steps = [], []
        current = _candidate(R, [], held_all, samples)
        masses["none"] = mass_of(full_fit(current)[0])
        s0, f0 = fold_scores(_fold_sums(R, current, g, folds, None, gram)[None])
        current_folds = f0[0]
        steps.append({"none": float(s0[0])})
        while True:
            tried = {}
            for n in offered:
                if n in chosen:
                    continue
                names_ = [m for m in CALIBRATION_TERMS if m in chosen or m == n]
                if sum(not calibration_term(m).held for m in names_) > 1:
                    continue
                c = _candidate(R, names_, held_all, samples)
                theta, phi, *_ = full_fit(c)
                masses[",".join(names_)] = mass_of(theta)
                if not physical(c):
                    refused.append(",".join(names_))
                    warnings.warn(
                        f"calibration {', '.join(names_)} refused: total mass {mass_of(theta):.4g} kg (least squares) "
                        f"against the URDF's {nominal_mass:.4g} kg, outside {MASS_BAND[0]:g}–{MASS_BAND[1]:g} ×: a fit "
                        "that predicts better by becoming unphysical",
                        stacklevel=3,
                    )
                    continue
                s, f = fold_scores(_fold_sums(R, c, g, folds, phi, gram)[None])
                tried[n] = (names_, float(s[0]), f[0])
            if not tried:
                break
            steps.append({f"+{k}": v[1] for k, v in tried.items()})
            best = min(tried, key=lambda k: tried[k][1])
            names_, score, fs = tried[best]
            if not better(fs, current_folds):
                break
            chosen, current_folds = names_, fs
        how = f"forward selection, {folds}-fold blocked cross-validation on the training recordings"
    estimates = {n: held_all[n] for n in chosen if n in held_all}
    c = _candidate(R, chosen, held_all, samples)
    if c.gravity_term is not None:
        theta, phi, W, Jphi = full_fit(c)
        sigma = _sigma(R, W, Jphi, c.y, theta)[W.shape[1] :]
        term = c.gravity_term
        estimates[term.name] = Estimate(term.names(samples), phi, sigma, term.units(samples), {})
    return Calibration(list(chosen), estimates, steps, how, masses, refused)
