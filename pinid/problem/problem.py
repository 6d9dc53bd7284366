"""The identification problem: recordings stacked into what every estimator takes, and its statistics.

:class:`IdentificationProblem` stacks one or more :class:`~pinid.data.dataset.Dataset` into the base
regressor ``W`` (rows × nb), the torques ``tau``, each row's joint and sample, row weights, the
base-parameter map and the nominal standard parameters.  :func:`base_statistics` gives the standard
deviations and condition numbers of a fit.  Estimators (:mod:`pinid.estimators`) take any object of
the :class:`Problem` protocol — this class or a segmental stage's :class:`~pinid.identification.segmental.SubProblem`.

Coulomb friction near rest
--------------------------
When a joint is nearly at rest, sign(dq) flips with velocity noise and the Coulomb column says
±1 at random; in reality the joint is in stiction and its friction torque is anywhere in
[−fc, fc].  Such rows carry no usable information about the model and bias the fit, so — when
the Coulomb term is in the model — the *row of that joint* at that sample (row ``k·nv + j``) is
dropped from the fit; the other joints' rows of the same sample stay.  The threshold per joint is

    v_rest_j = max(rest_fraction · max_k |dq_j|,  3 · σ̂_v,j)

with ``rest_fraction = 0.02`` and σ̂_v,j the velocity noise estimated from the data (the robust
standard deviation of the second difference of dq_j divided by √6, exact for white noise on a smooth
signal).  ``rest_velocity`` overrides it (a number or one per joint [rad/s]; 0 keeps every row).
Training metrics are over the rows used in the fit; validation metrics are over every sample.

Motor Coulomb friction (``motor_fc``) is the same at the motors: its column sign((G·dq)_m) flips with the
noise of the motor velocity, so at a sample where motor ``m`` is at rest (by the same rule applied to the
motor velocities G·dq) the rows of every joint it drives (``G[m, j] ≠ 0``) are dropped
(:func:`motor_kept_rows`) — whatever the joints' own velocities: a differential's motor stands still when
dq5 = −dq6 while both joints move.

``fit_joints`` leaves out every row of the other joints (their torque channel is not used; the joints
still move and are in the regressor's columns of the fitted rows, and are predicted and validated).

The tall regressor in blocks
----------------------------
A problem made by :meth:`IdentificationProblem.from_datasets` keeps the recordings and the rows kept
(:class:`RegressorRows`) instead of the tall ``W``: its Gram sums, compressed form, rank check and
predictions are accumulated ``_CHUNK`` samples at a time, so ``W`` is built (whole, once, cached) only
when an estimator reads ``problem.W`` (wls, rls, metaheuristics …) or the Gram matrix is too
ill-conditioned for Cholesky (then the compressed form needs a QR factorisation of the whole matrix).  Blocks
of at most ``KEEP_BLOCKS_BYTES`` in all (5 s at 5 kHz of a 6-DOF arm: 60 MB) are kept after a first pass
and read again by the Gram sums, the HAC σ and the predictions (issue 35); larger ones are rebuilt.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field
from typing import ClassVar, Protocol, runtime_checkable
from collections.abc import Iterator, Mapping, Sequence

import numpy as np
import scipy.linalg

from pinid.data.dataset import Dataset, as_dataset
from pinid.errors import DataError
from pinid.linalg import (
    RANK_TOL,
    augmented_r,
    cholesky_r,
    column_scale,
    gram_sums,
    qr_r,
    regrouped_blocks,
    row_blocks,
    unit_weights,
)
from pinid.model.base import BaseParameters, base_parameters
from pinid.model.physical import parameter_scale
from pinid.model.regressor import regressor, standard_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel, as_robot
from pinid.problem.cache import ProblemCache
from pinid.progress import progress
from pinid.problem.statistics import completed_standard
from pinid.problem.rows import (
    REST_FRACTION,
    fit_mask,
    kept_rows,
    motor_kept_rows,
    rest_threshold,
    rest_thresholds as rest_thresholds,  # re-exported for pinid/problem/floating.py (being merged away)
    kept_targets,
)

_CHUNK = 20_000  # samples per regressor chunk (bounds memory of the full standard regressor)
KEEP_BLOCKS_BYTES = 128 * 2**20  # regressor blocks kept after a first pass up to this size in all (module text)


@runtime_checkable
class Problem(Protocol):
    """What an estimator's ``fit`` may use: stacked rows of a linear-in-parameters torque model.

    :class:`IdentificationProblem` has all of it (and ``base``, the map to standard parameters, which
    only estimators of the standard parameters need); a segmental stage's
    :class:`~pinid.identification.segmental.SubProblem` has the rest.
    """

    model: RobotModel
    terms: TermSelection
    W: np.ndarray
    tau: np.ndarray
    joint: np.ndarray
    sample: np.ndarray
    weights: np.ndarray

    @property
    def nv(self) -> int: ...

    @property
    def nb(self) -> int: ...

    @property
    def rows(self) -> int: ...

    @property
    def names(self) -> list[str]: ...

    @property
    def nominal_base(self) -> np.ndarray: ...

    @property
    def natural_scale(self) -> np.ndarray: ...

    def compressed(self, weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]: ...


@dataclass
class RegressorRows:
    """What rebuilds the rows of a stacked base regressor: checked recordings and, per recording, which of
    its ``N·nv`` rows are kept (rows at rest dropped); see :func:`stack_rows` for the row order.  ``kept``: the
    blocks of a first pass, ``[(first row, W rows, samples)]``, when they total ≤ :data:`KEEP_BLOCKS_BYTES`."""

    model: RobotModel
    terms: TermSelection
    base: BaseParameters
    datasets: list[Dataset]
    keeps: list[np.ndarray]
    kept: list[tuple[int, np.ndarray, int]] | None = field(default=None, repr=False, compare=False)
    chunk: ClassVar[int] = _CHUNK  # samples per block of blocks()

    @property
    def count(self) -> int:
        """Number of rows kept."""
        return sum(int(np.count_nonzero(k)) for k in self.keeps)

    def blocks(self, *, bar=None) -> Iterator[tuple[int, np.ndarray]]:
        """``(first row, W rows)`` of the stacked base regressor, ``_CHUNK`` samples at a time, in order
        (``bar``: a progress bar advanced by the samples done); read-only from :attr:`kept` after a first pass."""
        if self.kept is not None:
            for row, Wk, samples in self.kept:
                yield row, Wk
                if bar is not None:
                    bar.update(samples)
            return
        passed = [] if self.count * self.base.count * 8 <= KEEP_BLOCKS_BYTES else None
        nv, row = self.model.nv, 0
        for ds, keep in zip(self.datasets, self.keeps):
            for start in range(0, ds.n, _CHUNK):
                stop = min(ds.n, start + _CHUNK)
                part = ds.select(slice(start, stop))
                Wk = base_regressor(self.model, self.terms, self.base, part, bar=bar, keep=keep[start * nv : stop * nv])
                if passed is not None:
                    Wk.flags.writeable = False  # shared by the passes to come
                    passed.append((row, Wk, stop - start))
                yield row, Wk
                row += len(Wk)
        self.kept = passed

    def samples(self) -> np.ndarray:
        """(rows kept,) each row's sample in the concatenated recordings (as :func:`stacked_targets`)."""
        parts, offset = [], 0
        for ds, keep in zip(self.datasets, self.keeps):
            parts.append(offset + np.flatnonzero(keep) // self.model.nv)
            offset += ds.n
        return parts[0] if len(parts) == 1 else np.concatenate(parts)

    def build(self) -> np.ndarray:
        """The whole stacked base regressor (rows kept × nb)."""
        W = np.empty((self.count, self.base.count))
        for row, Wk in self.blocks():
            W[row : row + len(Wk)] = Wk
        return W


@dataclass
class IdentificationProblem:
    """What an estimator is given.  Rows are stacked sample-major (row of joint ``joint[r]`` at ``sample[r]``).

    ``W``        (rows, nb) base regressor: ``W @ base ≈ tau`` [N·m]; built on first reading when the
                 problem has ``regressor_rows`` (see the module text), else the array given
    ``tau``      (rows,) measured joint torques [N·m]
    ``joint``    (rows,) index of each row's joint in ``model.joint_names``
    ``sample``   (rows,) index of each row's sample in the concatenated recordings
    ``weights``  (rows,) row weights (ones unless given); OLS minimises Σ w·r²
    ``base``     the :class:`~pinid.model.base.BaseParameters` map (``base.P @ θ_standard``)
    ``nominal``  (p,) the URDF's standard parameters (inertias, ``<dynamics>`` friction)
    ``recorded_tau`` (rows,) the torque as recorded at each row's sample (:func:`recorded_torque`), the
                 yardstick of the training error; None: ``tau`` is the torque as recorded
    ``offset_shift`` (rows,) the mean torque taken out of each recording and joint (offsets per recording)
    ``cache``    what is computed once from the rows and kept (:class:`ProblemCache`; not an argument)
    """

    cache: ProblemCache = field(default_factory=ProblemCache, init=False, repr=False, compare=False)
    model: RobotModel
    terms: TermSelection
    base: BaseParameters
    W: np.ndarray | None = field(repr=False, compare=False)  # a property, defined after the class
    tau: np.ndarray
    joint: np.ndarray
    sample: np.ndarray
    weights: np.ndarray
    nominal: np.ndarray
    samples: int = 0
    rest_velocity: np.ndarray | None = None
    dropped: np.ndarray | None = None
    sources: list[str] = field(default_factory=list)
    sample_rates: list[float] = field(default_factory=list)
    peak_velocity: np.ndarray | None = None
    regressor_rows: RegressorRows | None = field(default=None, repr=False, compare=False)
    fit_joints: list[str] | None = None  # the joints whose torque rows enter the fit (None: all)
    recorded_tau: np.ndarray | None = field(default=None, repr=False, compare=False)
    offset_shift: np.ndarray | None = field(default=None, repr=False, compare=False)
    #: predictions summed as over the whole ``W`` (rows in blocks of ``GRAM_BLOCK_ROWS``, the same digits as
    #: ``W @ base``) from the first estimator that fits on the whole rows (wls): what they were when it built W
    as_whole: bool = field(default=False, repr=False, compare=False)

    # ---------------------------------------------------------------- sizes and names
    @property
    def nv(self) -> int:
        """Number of joints."""
        return self.model.nv

    @property
    def nb(self) -> int:
        """Number of base parameters."""
        return self.base.count

    @property
    def rows(self) -> int:
        """Number of torque rows used."""
        return len(self.tau)

    @property
    def names(self) -> list[str]:
        """Names of the base parameters."""
        return list(self.base.names)

    @property
    def standard_names(self) -> list[str]:
        """Names of the standard parameters."""
        return list(self.base.standard_names)

    @property
    def nominal_base(self) -> np.ndarray:
        """The nominal (URDF) base parameters (round-off of cancelling terms set to 0)."""
        return self.base.shown(self.nominal)

    @property
    def natural_scale(self) -> np.ndarray:
        """Natural magnitude of every base parameter (nb,): ``|P|·s`` with ``s`` = per body M, M·L, M·L²
        (:func:`pinid.model.physical.parameter_scale`, from the nominal parameters) and 1 for joint terms."""
        return np.abs(self.base.P) @ parameter_scale(self.nominal, self.nv, len(self.terms))

    def summary(self) -> dict:
        """Plain-dict description of the data used."""
        joints = self.model.joint_names
        return {
            "sources": list(self.sources),
            "samples": int(self.samples),
            "rows": int(self.rows),
            "sample_rates_hz": [None if not np.isfinite(r) else float(r) for r in self.sample_rates],
            "rest_velocity": None
            if self.rest_velocity is None
            else {j: float(v) for j, v in zip(joints, self.rest_velocity)},
            "rows_dropped_at_rest": None if self.dropped is None else {j: int(v) for j, v in zip(joints, self.dropped)},
            "fit_joints": list(joints if self.fit_joints is None else self.fit_joints),
        }

    # ---------------------------------------------------------------- construction
    @classmethod
    def from_datasets(
        cls,
        model: RobotModel,
        datasets: Dataset | Sequence[Dataset],
        *,
        terms: TermSelection = TermSelection(),
        base: BaseParameters | None = None,
        rest_velocity: float | Sequence[float] | str | None = "auto",
        rest_fraction: float = REST_FRACTION,
        weights: np.ndarray | None = None,
        show_progress: bool | None = False,
        fit_joints: Sequence[str] | str | None = None,
    ) -> "IdentificationProblem":
        """Stack recordings with ``q, dq, ddq, tau`` into a problem (see the module text on rest).

        ``fit_joints``: the joints whose torque rows enter the fit (default all; see :func:`fit_mask`): the
        others still move and are in every row's regressor columns, only their own torque rows are left out.
        Raises DataError for missing joints or columns, NaN, too few rows for the number of base
        parameters, and a rank-deficient regressor (naming the parameters the data do not excite).
        """
        if isinstance(datasets, Dataset):
            datasets = [datasets]
        datasets = list(datasets)
        if not datasets:
            raise DataError("no recording given, expected at least one training recording")
        fit = fit_mask(model, fit_joints)
        if base is None:
            base = base_parameters(model, terms, joints=None if fit.all() else list(np.array(model.joint_names)[fit]))
        prepared = [check_dataset(ds, model) for ds in datasets]
        nv = model.nv
        thresholds = [rest_threshold(ds, model, terms, rest_velocity, rest_fraction) for ds in prepared]
        total = sum(ds.n for ds in prepared)
        keeps = [
            kept_rows(ds, thr) & motor_kept_rows(ds, model, terms, rest_velocity, rest_fraction)
            for ds, thr in zip(prepared, thresholds)
        ]
        dropped = total - np.sum([k.reshape(-1, nv).sum(axis=0) for k in keeps], axis=0)
        if not fit.all():
            keeps = [k & np.tile(fit, len(k) // nv) for k in keeps]
        tau, joint = kept_targets(prepared, keeps, nv)
        recorded = [recorded_torque(ds) for ds in prepared]
        # None when the torque as recorded is the torque itself (not prepared): no second copy of it
        recorded_tau = (
            None
            if all(r is ds.tau for r, ds in zip(recorded, prepared))
            else np.concatenate([r.reshape(-1)[k] for r, k in zip(recorded, keeps)])
        )
        del recorded
        rows = RegressorRows(model, terms, base, prepared, keeps)
        if weights is None:
            w = np.broadcast_to(np.float64(1.0), (len(tau),))  # unit weights, read-only: no array of ones
        else:
            w = np.asarray(weights, dtype=float).reshape(-1)
            if w.shape != (total * nv,):
                raise DataError(f"weights: {w.shape[0]} values, expected one per torque row ({total * nv})")
            w = w[np.concatenate(keeps)]
            if np.any(~np.isfinite(w)) or np.any(w < 0):
                raise DataError("weights: expected finite non-negative numbers")
        problem = cls(
            model,
            terms,
            base,
            None,
            tau,
            joint,
            None,  # ``sample``: computed from ``regressor_rows`` when read (not kept: 8 bytes per row)
            w,
            standard_parameters(model, terms),
            samples=total,
            rest_velocity=np.max(thresholds, axis=0),
            dropped=dropped,
            sources=[ds.source for ds in prepared],
            sample_rates=[ds.sample_rate for ds in prepared],
            peak_velocity=np.max([np.abs(ds.dq).max(axis=0) for ds in prepared], axis=0),
            regressor_rows=rows,
            fit_joints=[j for j, f in zip(model.joint_names, fit) if f],
            recorded_tau=recorded_tau,
        )
        bar = progress(total, "regressor", enabled=show_progress)  # the Gram pass of the rank check
        try:
            problem.check(bar=bar)
        finally:
            bar.close()
        return problem

    def check(self, *, bar=None) -> None:
        """DataError when there are too few rows or the data do not excite every base parameter (``bar``:
        a progress bar advanced by the samples of the Gram pass)."""
        nb, rows = self.nb, self.rows
        joints = self.model.joint_names
        hints = []
        if self.peak_velocity is not None:
            still = [j for j, v in zip(joints, self.peak_velocity) if v <= 1e-9]
            if still:
                hints.append(f"joint(s) {', '.join(still)} at rest in every sample")
        if self.dropped is not None and self.samples:
            rest = [
                j
                for j, d, v in zip(
                    joints, self.dropped, self.peak_velocity if self.peak_velocity is not None else np.ones(len(joints))
                )
                if d > 0.5 * self.samples and v > 1e-9
            ]
            if rest:
                hints.append(
                    f"joint(s) {', '.join(rest)} at rest in most samples (rows dropped for Coulomb friction, "
                    "see rest_velocity)"
                )
        if self.fit_joints is not None and len(self.fit_joints) < len(joints):
            hints.append(f"only the torque rows of {', '.join(self.fit_joints)} are fitted (fit joints)")
        hint = "; " + "; ".join(hints) if hints else ""
        if rows <= nb:
            raise DataError(
                f"{', '.join(self.sources)}: {rows} torque rows ({self.samples} samples × {self.nv} joints, "
                f"after dropping rows at rest) for {nb} base parameters; need more rows than parameters" + hint
            )
        norms = np.sqrt(np.maximum(np.diag(self.gram(bar=bar)[0]), 0.0))
        zero = np.flatnonzero(norms <= 1e-12 * max(norms.max(), 1e-300))
        if zero.size:
            names = [self.names[i] for i in zero]
            raise DataError(
                f"{', '.join(self.sources)}: rank-deficient regressor, the data do not excite "
                f"{', '.join(names)} (their columns are zero){hint}"
            )
        R = self.compressed()[0]
        # pivoted QR of R reveals the rank of the tall (column-scaled) regressor: RᵀR = AᵀA
        _, R2, piv = scipy.linalg.qr(R, pivoting=True)
        d = np.abs(np.diag(R2))
        rank = int(np.sum(d > RANK_TOL * d[0]))
        if rank < nb:
            names = [self.names[i] for i in piv[rank:]]
            raise DataError(
                f"{', '.join(self.sources)}: rank-deficient regressor (rank {rank} < {nb} base parameters), "
                f"the data do not excite {', '.join(names)} independently of the others{hint}"
            )

    # ---------------------------------------------------------------- the tall regressor, in blocks
    @property
    def blocked(self) -> bool:
        """True while ``W`` is not built and its rows come from ``regressor_rows`` block by block."""
        return self.__dict__.get("_W") is None and self.regressor_rows is not None

    def source_key(self) -> tuple:
        """The key of the :attr:`cache`'s values: ids of the rows' source, tau, weights (the same in a fork)."""
        source = self.regressor_rows if self.regressor_rows is not None else self.__dict__.get("_W")
        return (id(source), id(self.tau), id(self.weights))

    def gram(self, weights: np.ndarray | None = None, *, bar=None) -> tuple[np.ndarray, np.ndarray, float]:
        """``(G, b, yy)`` of :func:`pinid.linalg.gram_sums` for row ``weights`` (default ``self.weights``):
        over blocks of ``_CHUNK`` samples rebuilt from the recordings while ``W`` is not built (``bar``
        advanced by their samples), else over row blocks of ``W``.  Cached for the problem's own weights."""
        own = weights is None or weights is self.weights
        key = self.source_key()
        kept = self.cache.get("gram", key) if own else None
        if kept is not None:
            return kept
        w = unit_weights(self.weights if own else weights)
        if self.blocked:
            parts = (
                (Wk, self.tau[r : r + len(Wk)], None if w is None else w[r : r + len(Wk)])
                for r, Wk in self.regressor_rows.blocks(bar=bar)
            )
        else:
            parts = row_blocks(self.W, self.tau, w)
        sums = gram_sums(parts, self.nb)
        if own:
            self.cache.put("gram", sums, key)
        return sums

    def compressed(self, weights: np.ndarray | None = None):
        """``(R, c, rho, scale)`` of :func:`pinid.linalg.augmented_r` for ``weights`` (default
        ``self.weights``): Cholesky of the Gram matrix accumulated in blocks (:meth:`gram`), without the tall
        ``W``; QR of the whole ``W`` (built if needed) when the Gram matrix is ill-conditioned.  Cached for
        the problem's own weights."""
        own = weights is None or weights is self.weights
        if not own:  # the same sums as augmented_r(W, tau, weights), W built or not
            return self.weighted_compressed(weights)
        key = self.source_key()
        kept = self.cache.get("compressed", key) if own else None
        if kept is not None:
            return kept
        G, b, yy = self.gram(weights)
        out = cholesky_r(G, b, yy)
        if out is None:
            out = qr_r(self.W, self.tau, unit_weights(self.weights if own else weights), column_scale(G))
        if own:
            self.cache.put("compressed", out, key)
        return out

    def residual(self, base: np.ndarray) -> np.ndarray:
        """``tau − W @ base`` (rows,) [N·m]; block by block while ``W`` is not built (one array of rows)."""
        if not self.blocked:
            return self.tau - self.W @ base
        r = self.predict(base)
        return np.subtract(self.tau, r, out=r)

    def weighted_compressed(self, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
        """``augmented_r(W, tau, weights)`` (:func:`pinid.linalg.augmented_r`, the same sums over the same
        blocks of ``GRAM_BLOCK_ROWS`` rows) without building ``W`` while it is not built; the QR of the
        whole ``W`` when the Gram matrix is ill-conditioned.  Kept for the last ``weights`` array while it lives
        (it is not to be changed in place in between)."""
        if not self.blocked:
            return augmented_r(self.W, self.tau, weights)
        kept = self.cache.get("weighted", self.source_key())  # (weak reference to the weights, result)
        if kept is not None and kept[0]() is weights:  # the same array again (wls: its fit, then its result)
            return kept[1]
        w = unit_weights(weights)
        G, b, yy = gram_sums(regrouped_blocks((Wk for _, Wk in self.regressor_rows.blocks()), self.tau, w), self.nb)
        out = cholesky_r(G, b, yy)
        out = out if out is not None else qr_r(self.W, self.tau, w, column_scale(G))
        if isinstance(weights, np.ndarray):
            self.cache.put("weighted", (weakref.ref(weights), out), self.source_key())
        return out

    def predict(self, base: np.ndarray) -> np.ndarray:
        """``W @ base`` (rows,) [N·m]; block by block while ``W`` is not built (see :attr:`blocked`)."""
        if not self.blocked:
            return self.W @ base
        out = np.empty(self.rows)
        if self.as_whole:  # BLAS's matrix-vector product rounds the same on row blocks of a multiple of 4
            r = 0
            for Wk, _, _ in regrouped_blocks((Wk for _, Wk in self.regressor_rows.blocks()), self.tau):
                out[r : r + len(Wk)] = Wk @ base
                r += len(Wk)
            return out
        for r, Wk in self.regressor_rows.blocks():
            out[r : r + len(Wk)] = Wk @ base
        return out


def _get_W(self: IdentificationProblem) -> np.ndarray | None:
    W = self.__dict__.get("_W")
    if W is None and self.regressor_rows is not None:
        W = self.__dict__["_W"] = self.regressor_rows.build()
    return W


def _set_W(self: IdentificationProblem, value: np.ndarray | None) -> None:
    self.__dict__["_W"] = value
    if value is not None:  # a given matrix replaces the recordings' rows and what was computed from them
        rows = self.__dict__.get("regressor_rows")
        if rows is not None:  # the recordings' lengths still bound the HAC windows (pinid.problem.covariance)
            self.__dict__["recording_sizes"] = [ds.n for ds in rows.datasets]
            if self.__dict__.get("_sample") is None:  # kept from here on: the rows can no longer say it
                self.__dict__["_sample"] = rows.samples()
        self.__dict__["regressor_rows"] = None
        self.cache.forget("gram", "compressed")


# ``W`` is a dataclass field (positional, as before) read and written through this property
IdentificationProblem.W = property(
    _get_W, _set_W, doc="(rows, nb) base regressor, built whole on first reading from ``regressor_rows``."
)


def _get_sample(self: IdentificationProblem) -> np.ndarray | None:
    sample, rows = self.__dict__.get("_sample"), self.regressor_rows
    return rows.samples() if sample is None and rows is not None else sample  # not kept: read by few


# ``sample`` too (a dataclass field): from the recordings' kept rows when not given (:meth:`RegressorRows.samples`)
IdentificationProblem.sample = property(
    _get_sample, lambda self, v: self.__dict__.__setitem__("_sample", v), doc="(rows,) each row's sample."
)


#: Smallest RMS [N·m] of a recording's torques (all joints together) that counts as a torque signal: below
#: it (all-zero or numerically zero torques) there is nothing to identify from.
TORQUE_SIGNAL_MIN = 1e-9


def check_dataset(ds: Dataset, model: RobotModel) -> Dataset:
    """The recording in the model's joint order, checked: torques, dq, ddq present and finite."""
    if not isinstance(ds, Dataset):
        raise DataError(f"expected a pinid Dataset, got {type(ds).__name__}")
    ds = ds.reorder(model.joint_names)
    if ds.tau is None:
        raise DataError(f"{ds.source}: no torque (tau) columns; identification needs measured joint torques")
    for name in ("dq", "ddq"):
        if getattr(ds, name) is None:
            raise DataError(
                f"{ds.source}: no {name} columns; differentiate q first (pinid.data.preprocess.prepare, "
                "which identify() and `pinid identify` call for you)"
            )
    if ds.n == 0:
        raise DataError(f"{ds.source}: no samples")
    if not np.all(np.isfinite(ds.t)):
        k = int(np.flatnonzero(~np.isfinite(ds.t))[0])
        raise DataError(f"{ds.source}: time has NaN or infinite values (first at sample {k})")
    for name in ("q", "dq", "ddq", "tau"):
        a = getattr(ds, name)
        bad = ~np.isfinite(a)
        if bad.any():
            k, j = (int(x) for x in np.argwhere(bad)[0])
            raise DataError(
                f"{ds.source}: {name} of joint '{ds.joints[j]}' has {int(bad[:, j].sum())} NaN or "
                f"infinite value(s) (first at sample {k}, t = {ds.t[k]:.6g} s); clean or trim the recording"
            )
    rms = float(np.sqrt(np.mean(ds.tau**2)))
    if rms < TORQUE_SIGNAL_MIN:
        raise DataError(
            f"{ds.source}: no torque signal (RMS of tau {rms:.3g} N·m over every joint, below "
            f"{TORQUE_SIGNAL_MIN:g} N·m); expected measured joint torques"
        )
    return ds


def stack_rows(
    model: RobotModel,
    terms: TermSelection,
    base: BaseParameters,
    datasets: Sequence[Dataset],
    thresholds: Sequence[np.ndarray],
    *,
    bar=None,
    rest_velocity="auto",
    rest_fraction: float = REST_FRACTION,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(W_b, tau, joint, sample)`` of checked recordings stacked row ``k·nv + j``, without the rows whose
    joint speed is below its threshold (and the rows of the joints of a motor at rest: :func:`motor_kept_rows`
    with ``rest_velocity``, ``rest_fraction``); ``sample`` counts on across recordings.

    ``W_b`` is allocated once with the kept rows only and filled chunk by chunk, so the tall matrix exists
    once (not once whole and once without the rows at rest, nor once per recording and once concatenated)."""
    model = as_robot(model)
    nv = model.nv
    keeps = [
        kept_rows(ds, thr) & motor_kept_rows(ds, model, terms, rest_velocity, rest_fraction)
        for ds, thr in zip(datasets, thresholds)
    ]
    counts = [int(np.count_nonzero(k)) for k in keeps]
    W = np.empty((sum(counts), base.count))
    row = 0
    for ds, keep, m in zip(datasets, keeps, counts):
        base_regressor(model, terms, base, ds, bar=bar, keep=keep, out=W[row : row + m])
        row += m
    return (W, *stacked_targets(datasets, keeps, nv))


def stacked_targets(
    datasets: Sequence[Dataset], keeps: Sequence[np.ndarray], nv: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(tau, joint, sample)`` of the rows ``keeps`` of checked recordings, stacked as in :func:`stack_rows`."""
    if not isinstance(datasets, Sequence) or isinstance(datasets, str):
        raise DataError(f"datasets: got {type(datasets).__name__}, expected a list of Datasets")
    for ds in datasets:
        as_dataset(ds, "datasets")
    taus, joints, samples = [], [], []
    offset = 0
    for ds, keep in zip(datasets, keeps):
        taus.append(ds.tau.reshape(-1)[keep])
        joints.append(np.tile(np.arange(nv), ds.n)[keep])
        samples.append((offset + np.repeat(np.arange(ds.n), nv))[keep])
        offset += ds.n
    if len(taus) == 1:
        return taus[0], joints[0], samples[0]
    return np.concatenate(taus), np.concatenate(joints), np.concatenate(samples)


def base_regressor(
    model: RobotModel,
    terms: TermSelection,
    base: BaseParameters,
    ds: Dataset,
    *,
    bar=None,
    keep: np.ndarray | None = None,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Stacked base regressor ``(N·nv, nb)`` of a checked recording, computed in chunks to bound memory.

    ``keep`` (N·nv,) booleans: only those rows, in order; ``out``: the array to fill (kept rows × nb)."""
    model = as_robot(model)
    n, nv = ds.n, model.nv
    rows = n * nv if keep is None else int(np.count_nonzero(keep))
    if out is None:
        out = np.empty((rows, base.count))
    elif out.shape != (rows, base.count):
        raise ValueError(f"out: shape {out.shape}, expected {(rows, base.count)}")
    r = 0
    for start in range(0, n, _CHUNK):
        stop = min(n, start + _CHUNK)
        W = regressor(model, ds.q[start:stop], ds.dq[start:stop], ds.ddq[start:stop], terms)
        if keep is None:
            np.take(W, base.independent, axis=1, out=out[start * nv : stop * nv])
        else:
            k = np.flatnonzero(keep[start * nv : stop * nv])
            out[r : r + len(k)] = W[np.ix_(k, base.independent)]
            r += len(k)
        if bar is not None:
            bar.update(stop - start)
    return out


def recorded_torque(ds: Dataset) -> np.ndarray:
    """``(N, nv)`` torque as recorded [N·m] at the samples of a prepared recording: the yardstick of every
    torque error (see docs/identification.md, "The yardstick").

    :func:`pinid.data.preprocess.prepare` keeps the recording as given in ``meta["recorded"]``.  Preprocessing trims and
    decimates, which keeps recorded sample times: there the recorded value itself is taken.  When it
    resampled (jittered time stamps, ``rate=``), the prepared times fall between recorded samples and the
    recorded torque is interpolated linearly to them (no filter).  A recording that was not prepared is its
    own record: ``ds.tau``.
    """
    rec = as_dataset(ds).meta.get("recorded")
    if not isinstance(rec, Dataset) or rec.tau is None or rec.n < 2:
        return ds.tau
    rec = rec.reorder(list(ds.joints))
    tr, tp = rec.t, ds.t
    if np.any(np.diff(tr) <= 0):
        return ds.tau
    k = np.clip(np.searchsorted(tr, tp), 1, rec.n - 1)
    k -= (tp - tr[k - 1]) < (tr[k] - tp)  # the nearest recorded sample
    if np.all(np.abs(tr[k] - tp) <= 1e-6 * float(np.median(np.diff(tr)))):
        return rec.tau[k]
    return np.column_stack([np.interp(tp, tr, rec.tau[:, j]) for j in range(rec.nv)])


def predict_torque(
    model: RobotModel,
    terms: TermSelection,
    base: BaseParameters,
    ds: Dataset,
    values: np.ndarray | Mapping[str, np.ndarray],
):
    """Predicted torques ``(N, nv)`` [N·m] on a checked recording for base ``values`` (or a dict of them).

    Computed chunk by chunk (``_CHUNK`` samples): the recording's tall regressor never exists whole.  Base
    parameters of some joints' rows only (``base.fit_joints``, ``--fit-joints``) predict every joint through
    the standard set nearest the nominal one with those base values (:func:`completed_standard`): exact on
    the fitted joints, the nominal values where their rows identify nothing."""
    ds = check_dataset(ds, model)
    single = not isinstance(values, Mapping)
    items = {None: values} if single else dict(values)
    if base.fit_joints is not None:
        theta = {k: completed_standard(model, terms, base, v) for k, v in items.items()}
        out = {k: np.empty((ds.n, model.nv)) for k in items}
        for start in range(0, ds.n, _CHUNK):
            part = ds.select(slice(start, min(ds.n, start + _CHUNK)))
            W = regressor(model, part.q, part.dq, part.ddq, terms)
            for k, th in theta.items():
                out[k][start : start + part.n] = (W @ th).reshape(part.n, model.nv)
        return out[None] if single else out
    out = {k: np.empty((ds.n, model.nv)) for k in items}
    for start in range(0, ds.n, _CHUNK):
        part = ds.select(slice(start, min(ds.n, start + _CHUNK)))
        Wb = base_regressor(model, terms, base, part)
        for k, v in items.items():
            out[k][start : start + part.n] = (Wb @ v).reshape(part.n, model.nv)
    return out[None] if single else out
