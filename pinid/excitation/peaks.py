"""The kinematic limits as constraints at each signal's peaks: a few rows instead of one per grid point.

The limits of an excitation design, ``A x <= b`` on a grid of the period
(:meth:`~pinid.excitation.problem.DesignProblem.linear_constraints`), come in blocks: per joint, q up,
q down, dq up, dq down, ddq up, ddq down, one row per grid point.  A block holds iff the signal's local
maxima over the period do, and a Fourier series of N harmonics has at most N of them.  So
:class:`PeakConstraints` gives SLSQP N rows per block: at each evaluation it finds the signal's local
maxima on the grid, refines each to the exact maximum between grid points (Newton steps on the analytic
derivatives), and returns ``b − a(t*)·x`` with the row ``a(t*)`` of the limit at that instant — the
constraint ``max_t s(t) <= b`` of the whole period, smooth while the peak exists (its gradient is the row
at the peak: ``s'(t*) = 0``).  A peak keeps its slot from one evaluation to the next (nearest in time), so
that SLSQP's multipliers follow the same peak; an empty slot is a row of zeros with a
positive value (|b| + 1), satisfied whatever x.

SLSQP's subproblem, most of a design's time, is linear in its rows: 6·nv·N of them instead of
6·nv·grid (24 instead of 200–400 per joint and signal).
"""

from __future__ import annotations

import numpy as np

#: Newton steps refining a grid maximum to the exact one
NEWTON_STEPS = 3


class PeakConstraints:
    """``fun(x)`` and ``jac(x)`` of SLSQP's inequality constraints (``>= 0``) at the peaks of every block of
    ``A x <= b`` (``block`` grid points ``times`` of the period each, in the order of
    :meth:`DesignProblem.linear_constraints`) of a :class:`~pinid.excitation.problem.DesignProblem`."""

    def __init__(self, problem, A: np.ndarray, b: np.ndarray) -> None:
        self.problem = problem
        self.A, self.b = A, b
        self.times = problem.check_times
        n, m = len(self.times), problem.m
        self.n, self.K = n, int(problem.N)
        self.blocks = len(b) // n  # 6 per joint
        self.bound = b.reshape(self.blocks, n)[:, 0]
        beta = np.arange(self.blocks)
        self.joint, kind = beta // 6, beta % 6
        self.order, self.sign = kind // 2, np.where(kind % 2 == 0, 1.0, -1.0)
        self.kw = np.arange(1, problem.N + 1) * problem.w
        self.T, self.m, self.d = problem.T, m, problem.d
        self.offsets = problem.spec.optimize_offsets
        self.slots = np.full((self.blocks, self.K), np.nan)  # times of the peaks each slot follows
        self._key, self._out = None, None

    def _coefficients(self, x: np.ndarray) -> np.ndarray:
        """``(blocks, 2N)``: sign × [a_1..a_N, b_1..b_N] of each block's joint."""
        Z = x[: self.problem.nv * self.m].reshape(self.problem.nv, self.m)
        C = Z @ self.T.T
        return C[self.joint] * self.sign[:, None]

    def _derivative(self, C: np.ndarray, t: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``d^p/dt^p`` of the series ``C (P, 2N)`` at times ``t (P,)``, order ``p (P,)``."""
        phase = np.outer(t, self.kw) + 0.5 * np.pi * p[:, None]
        scale = self.kw[None, :] ** p[:, None]
        N = self.K
        return (scale * (C[:, :N] * np.sin(phase) + C[:, N:] * np.cos(phase))).sum(axis=1)

    def _peaks(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Times ``(blocks, K)`` of every block's local maxima (NaN: none), refined between grid points; a
        constant signal has one, at its first grid point."""
        v = (self.A @ x).reshape(self.blocks, self.n)
        peak = (v > np.roll(v, 1, axis=1)) & (v >= np.roll(v, -1, axis=1))
        flat = ~peak.any(axis=1)  # a joint at rest: one row still (its offset may be a variable)
        peak[flat, np.argmax(v[flat], axis=1)] = True
        score = np.where(peak, v, -np.inf)
        idx = np.argsort(-score, axis=1, kind="stable")[:, : self.K]
        found = np.take_along_axis(score, idx, axis=1) > -np.inf
        h = self.times[1] - self.times[0]
        t = self.times[idx].astype(float)
        rows, cols = np.nonzero(found)
        if len(rows):
            C = self._coefficients(x)[rows]
            p = self.order[rows]
            t0 = t[rows, cols]
            tt = t0.copy()
            for _ in range(NEWTON_STEPS):
                d1, d2 = self._derivative(C, tt, p + 1), self._derivative(C, tt, p + 2)
                step = np.where(d2 < 0, -d1 / np.where(d2 < 0, d2, -1.0), 0.0)
                tt = np.clip(tt + step, t0 - h, t0 + h)
            t[rows, cols] = tt
        t[~found] = np.nan
        return t

    def _assign(self, t: np.ndarray) -> np.ndarray:
        """The new peak times ``t (blocks, K)`` placed in the slots whose previous peak is nearest in time."""
        old, period = self.slots, self.times[-1] + (self.times[1] - self.times[0])
        diff = np.abs(old[:, :, None] - t[:, None, :]) % period
        dist = np.minimum(diff, period - diff)
        dist = np.where(np.isnan(dist), np.inf, dist)
        new = np.full_like(old, np.nan)
        taken_old = np.zeros(old.shape, dtype=bool)
        taken_new = np.isnan(t)
        B = np.arange(self.blocks)
        for _ in range(self.K):
            D = np.where(taken_old[:, :, None] | taken_new[:, None, :], np.inf, dist)
            flat = D.reshape(self.blocks, -1).argmin(axis=1)
            i, j = np.divmod(flat, self.K)
            ok = np.isfinite(D[B, i, j])
            new[B[ok], i[ok]] = t[B[ok], j[ok]]
            taken_old[B[ok], i[ok]] = True
            taken_new[B[ok], j[ok]] = True
        for _ in range(self.K):  # peaks left (new ones): the first free slot
            left = ~taken_new.all(axis=1)
            if not left.any():
                break
            j = np.argmin(taken_new, axis=1)
            i = np.argmin(taken_old, axis=1)
            new[B[left], i[left]] = t[B[left], j[left]]
            taken_old[B[left], i[left]] = True
            taken_new[B[left], j[left]] = True
        self.slots = new
        return new

    def _rows(self, t: np.ndarray) -> np.ndarray:
        """``(blocks·K, d)``: the limit's row at each slot's time (zeros for an empty slot)."""
        beta = np.repeat(np.arange(self.blocks), self.K)
        tt = t.reshape(-1)
        full = ~np.isnan(tt)
        out = np.zeros((len(tt), self.d))
        b, ts = beta[full], tt[full]
        p = self.order[b]
        phase = np.outer(ts, self.kw) + 0.5 * np.pi * p[:, None]
        scale = self.kw[None, :] ** p[:, None]
        basis = np.hstack([scale * np.sin(phase), scale * np.cos(phase)]) @ self.T  # (P, m)
        j = self.joint[b]
        r = np.flatnonzero(full)
        cols = j[:, None] * self.m + np.arange(self.m)[None, :]
        out[r[:, None], cols] = basis * self.sign[b][:, None]
        if self.offsets:
            pos = p == 0
            out[r[pos], self.problem.nv * self.m + j[pos]] = self.sign[b][pos]
        return out

    def _evaluate(self, x: np.ndarray):
        key = x.tobytes()
        if key != self._key:
            slots = self._assign(self._peaks(x))
            rows = self._rows(slots)
            values = np.repeat(self.bound, self.K) - rows @ x
            empty = np.isnan(slots.reshape(-1))
            values[empty] = np.repeat(np.abs(self.bound) + 1.0, self.K)[empty]  # satisfied whatever x
            self._key, self._out = key, (values, -rows)
        return self._out

    def fun(self, x: np.ndarray) -> np.ndarray:
        return self._evaluate(np.asarray(x, dtype=float))[0]

    def jac(self, x: np.ndarray) -> np.ndarray:
        return self._evaluate(np.asarray(x, dtype=float))[1]
