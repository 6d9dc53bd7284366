"""Recursive least squares with a forgetting factor (seed 000, Eq. (6)), keeping every estimate.

The rows of the problem are processed one at a time in their stacked order (sample-major: at each
sample, every joint's row), each with its row weight ``w``.  With the forgetting factor ``λ ∈ (0, 1]``::

    K  = P·h / (λ/w + hᵀ·P·h)
    x ← x + K·(τ − hᵀ·x)                       (the a-priori error times the gain)
    P ← (P − K·hᵀ·P) / λ

which minimises ``Σ_k λ^(N−k)·w_k·(τ_k − h_kᵀ x)²`` (plus a prior term) after N rows.  The start
(``init``): ``"exact"`` (default) — batch least squares on the first block of rows whose Gram matrix is
well conditioned (condition number < 1e8, doubling from 4·nb rows), then recursion from there, so there
is no prior at all and ``RLS(λ=1)`` ends at the batch least-squares solution to rounding (~1e-10
relatively, tested); ``"prior"`` (also the fallback when no such block exists in the first half of the
rows) — ``x0`` with covariance ``p0·I`` in column-scaled coordinates (every column of unit RMS), the
textbook start, which biases the result by a ridge term of relative size ~1/(p0·rows).

Seed 000 writes Eq. (6) with a "weight" in two places: ``K = P·H/(Hᵀ·P·H + 1/weight)`` and
``P ← (1/weight)·(I − K·Hᵀ)·P``.  That is this recursion with ``λ = weight`` and a constant measurement
weight (``w = weight²``), which does not change the estimate; so ``forgetting`` is the seed's "weight".
The seed gives no value; ``λ = 1`` is the default here.

**The search box.**  The seed runs RLS to see how much the estimates "fluctuate" and takes each
parameter's [min, max] over the run as the search box of PSO (its Tables 3 and 5; RLS-PSO,
:class:`pinid.estimators.metaheuristic.RLSPSO`).  The first rows give wild estimates (a handful of
rows cannot determine nb parameters), so the first ``burn_in`` of the rows are left out of the box
(default 10 %; a fraction < 1 or a number of rows).  ``widen`` enlarges the box by that fraction of its
width on each side (default 0: the seed's box).  With λ = 1 the final estimate — the least-squares one —
is always inside the box, so PSO inside it can at best find the least-squares solution on a squared
cost.

Fitted values: ``base_`` (the final estimate), ``estimates_`` (rows × nb, the estimate after every row),
``box_`` (``(lower, upper)`` over the rows after the burn-in), ``history_`` (the RMS of the a-priori
error over each tenth of the rows: how well the running estimate predicted the next rows).
"""

from __future__ import annotations

import copy

import numpy as np

from pinid.errors import SpecError
from pinid.problem.cache import data_key
from pinid.estimators.base import Estimator, Setting
from pinid.problem.problem import Problem


class RLS(Estimator):
    """Recursive least squares with forgetting factor (seed 000 Eq. (6)); see the module text.

    Settings: ``forgetting`` λ ∈ (0, 1] (default 1), ``init`` ("exact" (default) or "prior"), ``p0``
    (initial covariance of the prior start in column-scaled coordinates, default 1e6), ``x0`` (its mean:
    "zero" (default), "nominal" — the URDF's base parameters — or an array), ``burn_in`` (fraction of the rows, or a number of rows, left out of the box; default 0.1),
    ``widen`` (extra fraction of the box's width on each side, default 0).
    """

    name = "rls"
    assumptions = "as OLS; with `forgetting` < 1, parameters that drift in time (older rows count less)"
    description = "recursive least squares with forgetting factor (seed 000 Eq. (6)); its range defines a box"
    colour = "#8c564b"
    history = "rows"
    settings = {
        "forgetting": Setting("float", low=0.0, high=1.0, low_open=True, help="forgetting factor λ"),
        "init": Setting("str", choices=("exact", "prior"), help="start from an exact fit of the first rows, or x0"),
        "p0": Setting("float", low=0.0, low_open=True, help="initial covariance scale (init='prior')"),
        "x0": Setting("any", help="'zero', 'nominal' or nb numbers (init='prior')"),
        "burn_in": Setting("float", low=0.0, help="fraction of the rows (< 1) or number of rows left out of the box"),
        "widen": Setting("float", low=0.0, help="widen the box by this fraction of its width on each side"),
    }

    def __init__(
        self,
        forgetting: float = 1.0,
        init: str = "exact",
        p0: float = 1e6,
        x0="zero",
        burn_in: float = 0.1,
        widen: float = 0.0,
    ) -> None:
        self.forgetting = forgetting
        self.init = init
        self.p0 = p0
        self.x0 = x0
        self.burn_in = burn_in
        self.widen = widen

    def _check(self, problem) -> tuple[float, int]:
        lam = float(self.forgetting)
        if not 0.0 < lam <= 1.0:
            raise SpecError(f"rls: forgetting factor {self.forgetting!r}, expected in (0, 1]")
        if not float(self.p0) > 0:
            raise SpecError(f"rls: p0 {self.p0!r}, expected > 0")
        if not float(self.widen) >= 0:
            raise SpecError(f"rls: widen {self.widen!r}, expected ≥ 0")
        rows = len(problem.tau)
        b = float(self.burn_in)
        if not b >= 0:
            raise SpecError(f"rls: burn_in {self.burn_in!r}, expected a fraction in [0, 1) or a number of rows")
        skip = int(round(b * rows)) if b < 1 else int(b)
        if skip >= rows:
            raise SpecError(f"rls: burn_in of {skip} rows leaves none of the {rows} rows for the box")
        return lam, skip

    def fit(self, problem: Problem) -> "RLS":
        """Run the recursion over the problem's rows in order; sets ``base_``, ``history_`` and the search box
        ``box_``.  The run is kept in the problem's ``cache`` (when it has one) for these settings: the
        ``rls`` method and RLS-PSO's box on the same problem run it once (it is deterministic)."""
        lam, skip = self._check(problem)
        cache = getattr(problem, "cache", None)
        x0 = self.x0 if isinstance(self.x0, str) else np.asarray(self.x0, dtype=float).tobytes()
        key = (*data_key(problem), lam, self.init, self.p0, x0, skip, self.widen)
        kept = None if cache is None else cache.get("rls", key)
        if kept is None:
            self._run(problem, lam, skip)
            if cache is not None:
                cache.put("rls", copy.deepcopy({k: getattr(self, k) for k in _FITTED}), key)
        else:
            self.__dict__.update(copy.deepcopy(kept))
        return self

    def shared_work(self) -> tuple[tuple[str, tuple], ...]:
        """This run, kept in the problem's cache by :meth:`fit`: the ``rls`` method and RLS-PSO's box share it."""
        params = self.get_params()  # x0 may be numbers: as a tuple, so that equal runs compare equal
        return (("rls", tuple((k, tuple(np.ravel(v).tolist()) if np.ndim(v) else v) for k, v in params.items())),)

    def _run(self, problem: Problem, lam: float, skip: int) -> None:
        W = np.asarray(problem.W, dtype=float)
        tau = np.asarray(problem.tau, dtype=float)
        w = np.asarray(problem.weights, dtype=float) if problem.weights is not None else np.ones(len(tau))
        rows, nb = W.shape
        # column scaling: every column of unit RMS, so that one P0 suits every parameter
        scale = np.sqrt(np.einsum("ij,ij->j", W, W) / max(rows, 1))
        scale[scale == 0] = 1.0
        H = W / scale
        if isinstance(self.x0, str):
            if self.x0 == "zero":
                z = np.zeros(nb)
            elif self.x0 == "nominal":
                z = np.asarray(problem.nominal_base, dtype=float) * scale
            else:
                raise SpecError(f"rls: x0 {self.x0!r}, expected 'zero', 'nominal' or {nb} numbers")
        else:
            z = np.asarray(self.x0, dtype=float).reshape(-1)
            if z.shape != (nb,):
                raise SpecError(f"rls: x0 has {z.size} values, expected {nb}")
            z = z * scale
        P = np.eye(nb) * float(self.p0)
        path = np.empty((rows, nb))
        err = np.empty(rows)
        inv_lam = 1.0 / lam
        start = 0
        if self.init == "exact":
            found = _exact_start(H, tau, w, lam)
            if found is not None:
                start, z, P = found
                path[:start] = z
                err[:start] = np.nan  # never predicted a priori: left out of history_
        elif self.init != "prior":
            raise SpecError(f"rls: init {self.init!r}, expected 'exact' or 'prior'")
        for k in range(start, rows):  # sequential by nature; ~5 µs per row for 10 parameters
            h = H[k]
            Ph = P @ h
            wk = w[k]
            if wk <= 0:
                path[k] = z
                err[k] = np.nan  # a row of weight 0 is not predicted
                continue
            e = tau[k] - h @ z
            K = Ph / (lam / wk + h @ Ph)
            z = z + K * e
            P = (P - np.outer(K, Ph)) * inv_lam if lam != 1.0 else P - np.outer(K, Ph)
            if k % 64 == 0:
                P = 0.5 * (P + P.T)  # rounding makes P drift from symmetric
            path[k] = z
            err[k] = e
        est = path / scale
        lower, upper = est[skip:].min(axis=0), est[skip:].max(axis=0)
        if self.widen:
            pad = float(self.widen) * (upper - lower)
            lower, upper = lower - pad, upper + pad
        self.base_ = est[-1].copy()
        self.estimates_ = est
        self.box_ = (lower, upper)
        self.standard_ = None
        self.weights_ = None
        tenth = np.array_split(err, 10)
        self.history_ = [float(np.sqrt(np.nanmean(c**2))) if np.isfinite(c).any() else float("nan") for c in tenth]
        self.status_ = "ok"
        names = list(problem.names)
        self.info_ = {
            "forgetting": lam,
            "rows": int(rows),
            "burn_in_rows": int(skip),
            "box": {"lower": dict(zip(names, map(float, lower))), "upper": dict(zip(names, map(float, upper)))},
            "a_priori_error_rms_per_tenth": self.history_,
        }


#: What :meth:`RLS.fit` sets (kept in the problem's cache).
_FITTED = ("base_", "estimates_", "box_", "standard_", "weights_", "history_", "status_", "info_")


def _exact_start(H: np.ndarray, tau: np.ndarray, w: np.ndarray, lam: float):
    """``(n0, z0, P0)``: least squares on the first ``n0`` rows, the smallest block (doubling from 4·nb)
    whose Gram matrix has a condition number below 1e8; None when no such block exists in the first half
    of the rows (the caller then starts from the prior)."""
    rows, nb = H.shape
    n0 = 4 * nb
    while n0 <= rows // 2:
        Hw = H[:n0] * w[:n0, None]
        G = Hw.T @ H[:n0]
        ev = np.linalg.eigvalsh(G)
        if ev[0] > 1e-8 * ev[-1] and ev[0] > 0:
            # forgetting within the block: weights λ^(n0−1−k), the same as the recursion would give
            f = lam ** np.arange(n0 - 1, -1, -1) if lam != 1.0 else None
            if f is not None:
                Hw = Hw * f[:, None]
                G = Hw.T @ H[:n0]
            P = np.linalg.inv(G)
            P = 0.5 * (P + P.T)
            z = P @ (Hw.T @ tau[:n0])
            return n0, z, P
        n0 *= 2
    return None
