"""Identification: from a model and recordings to base (and standard) parameters, validated.

* :class:`IdentificationProblem` stacks one or more :class:`~pinid.data.dataset.Dataset` into what every
  estimator takes: the base regressor ``W`` (rows × nb), the torques ``tau``, each row's joint and
  sample, row weights, the base-parameter map and the nominal standard parameters.
* :func:`identify` runs several estimators on one problem, checks every result for physical
  consistency, validates on other recordings and returns an :class:`Identification` — a result per
  method (:class:`IdentificationResult`) and, through ``.model``, an
  :class:`~pinid.identification.identified.IdentifiedModel` for controller code.

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
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Mapping, Sequence

import numpy as np

from pinid.model.base import BaseParameters, base_parameters
from pinid.data.dataset import Dataset
from pinid.errors import DataError, PinidError, SpecError
from pinid.io import jsonable, read_json
from pinid.identification.metrics import TorqueMetrics, torque_metrics
from pinid.model.robot import RobotModel
from pinid.model.regressor import JointTerms, regressor, standard_parameters

#: Default methods of :func:`identify` and ``pinid identify``.
DEFAULT_METHODS: tuple[str, ...] = ("ols", "wls", "sdp")
#: Default fraction of a joint's largest speed below which its row counts as "at rest".
REST_FRACTION = 0.02
_CHUNK = 20_000  # samples per regressor chunk (bounds memory of the full standard regressor)


# ====================================================================== the problem
@dataclass
class IdentificationProblem:
    """What an estimator is given.  Rows are stacked sample-major (row of joint ``joint[r]`` at ``sample[r]``).

    ``W``        (rows, nb) base regressor: ``W @ base ≈ tau`` [N·m]
    ``tau``      (rows,) measured joint torques [N·m]
    ``joint``    (rows,) index of each row's joint in ``model.joint_names``
    ``sample``   (rows,) index of each row's sample in the concatenated recordings
    ``weights``  (rows,) row weights (ones unless given); OLS minimises Σ w·r²
    ``base``     the :class:`~pinid.model.base.BaseParameters` map (``base.P @ θ_standard``)
    ``nominal``  (p,) the URDF's standard parameters (inertias, ``<dynamics>`` friction)
    """

    model: RobotModel
    terms: JointTerms
    base: BaseParameters
    W: np.ndarray
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
        """The nominal (URDF) base parameters."""
        return self.base.from_standard(self.nominal)

    def summary(self) -> dict:
        """Plain-dict description of the data used."""
        joints = self.model.joint_names
        return {
            "sources": list(self.sources),
            "samples": int(self.samples),
            "rows": int(self.rows),
            "sample_rates_hz": [None if not np.isfinite(r) else float(r) for r in self.sample_rates],
            "rest_velocity": None if self.rest_velocity is None else
            {j: float(v) for j, v in zip(joints, self.rest_velocity)},
            "rows_dropped_at_rest": None if self.dropped is None else
            {j: int(v) for j, v in zip(joints, self.dropped)},
        }

    # ---------------------------------------------------------------- construction
    @classmethod
    def from_datasets(
        cls,
        model: RobotModel,
        datasets: Dataset | Sequence[Dataset],
        *,
        terms: JointTerms = JointTerms(),
        base: BaseParameters | None = None,
        rest_velocity: float | Sequence[float] | str | None = "auto",
        rest_fraction: float = REST_FRACTION,
        weights: np.ndarray | None = None,
        show_progress: bool | None = False,
    ) -> "IdentificationProblem":
        """Stack recordings with ``q, dq, ddq, tau`` into a problem (see the module text on rest).

        Raises DataError for missing joints or columns, NaN, too few rows for the number of base
        parameters, and a rank-deficient regressor (naming the parameters the data do not excite).
        """
        if isinstance(datasets, Dataset):
            datasets = [datasets]
        datasets = list(datasets)
        if not datasets:
            raise DataError("no recording given, expected at least one training recording")
        base = base if base is not None else base_parameters(model, terms)
        prepared = [check_dataset(ds, model) for ds in datasets]
        nv = model.nv
        thresholds = [rest_threshold(ds, model, terms, rest_velocity, rest_fraction) for ds in prepared]
        total = sum(ds.n for ds in prepared)
        from pinid.progress import progress

        bar = progress(total, "regressor", enabled=show_progress)
        try:
            W, tau, joint, sample = stack_rows(model, terms, base, prepared, thresholds, bar=bar)
        finally:
            bar.close()
        dropped = np.array([total - int(np.sum(joint == j)) for j in range(nv)])
        if weights is None:
            w = np.ones(len(tau))
        else:
            w = np.asarray(weights, dtype=float).reshape(-1)
            if w.shape != (total * nv,):
                raise DataError(f"weights: {w.shape[0]} values, expected one per torque row ({total * nv})")
            w = w[np.concatenate([(np.abs(ds.dq) >= thr).reshape(-1) for ds, thr in zip(prepared, thresholds)])]
            if np.any(~np.isfinite(w)) or np.any(w < 0):
                raise DataError("weights: expected finite non-negative numbers")
        problem = cls(model, terms, base, W, tau, joint, sample, w, standard_parameters(model, terms),
                      samples=total, rest_velocity=np.max(thresholds, axis=0), dropped=dropped,
                      sources=[ds.source for ds in prepared], sample_rates=[ds.sample_rate for ds in prepared],
                      peak_velocity=np.max([np.abs(ds.dq).max(axis=0) for ds in prepared], axis=0))
        problem.check()
        return problem

    def check(self) -> None:
        """DataError when there are too few rows or the data do not excite every base parameter."""
        nb, rows = self.nb, self.rows
        joints = self.model.joint_names
        hints = []
        if self.peak_velocity is not None:
            still = [j for j, v in zip(joints, self.peak_velocity) if v <= 1e-9]
            if still:
                hints.append(f"joint(s) {', '.join(still)} at rest in every sample")
        if self.dropped is not None and self.samples:
            rest = [j for j, d, v in zip(joints, self.dropped, self.peak_velocity if self.peak_velocity is not None
                                         else np.ones(len(joints))) if d > 0.5 * self.samples and v > 1e-9]
            if rest:
                hints.append(f"joint(s) {', '.join(rest)} at rest in most samples (rows dropped for Coulomb friction, "
                             "see rest_velocity)")
        hint = "; " + "; ".join(hints) if hints else ""
        if rows <= nb:
            raise DataError(f"{', '.join(self.sources)}: {rows} torque rows ({self.samples} samples × {self.nv} joints, "
                            f"after dropping rows at rest) for {nb} base parameters; need more rows than parameters"
                            + hint)
        norms = np.sqrt(np.einsum("ij,ij,i->j", self.W, self.W, self.weights))
        zero = np.flatnonzero(norms <= 1e-12 * max(norms.max(), 1e-300))
        if zero.size:
            names = [self.names[i] for i in zero]
            raise DataError(f"{', '.join(self.sources)}: rank-deficient regressor, the data do not excite "
                            f"{', '.join(names)} (their columns are zero){hint}")
        import scipy.linalg

        R = self.compressed()[0]
        # pivoted QR of R reveals the rank of the tall (column-scaled) regressor: RᵀR = AᵀA
        _, R2, piv = scipy.linalg.qr(R, pivoting=True)
        d = np.abs(np.diag(R2))
        rank = int(np.sum(d > 1e-10 * d[0]))
        if rank < nb:
            names = [self.names[i] for i in piv[rank:]]
            raise DataError(f"{', '.join(self.sources)}: rank-deficient regressor (rank {rank} < {nb} base parameters), "
                            f"the data do not excite {', '.join(names)} independently of the others{hint}")

    def compressed(self, weights: np.ndarray | None = None):
        """``(R, c, rho, scale)`` of :func:`pinid.estimators.base.augmented_r` for ``weights`` (default
        ``self.weights``) — one QR pass over the tall regressor, cached for the problem's own weights."""
        from pinid.estimators.base import augmented_r

        if weights is not None and weights is not self.weights:
            return augmented_r(self.W, self.tau, weights)
        key = (id(self.W), id(self.tau), id(self.weights), self.W.shape)
        cache = self.__dict__.get("_compressed")
        if cache is None or cache[0] != key:
            cache = (key, augmented_r(self.W, self.tau, self.weights))
            self.__dict__["_compressed"] = cache
        return cache[1]


def check_dataset(ds: Dataset, model: RobotModel) -> Dataset:
    """The recording in the model's joint order, checked: torques, dq, ddq present and finite."""
    if not isinstance(ds, Dataset):
        raise DataError(f"expected a pinid Dataset, got {type(ds).__name__}")
    ds = ds.reorder(model.joint_names)
    if ds.tau is None:
        raise DataError(f"{ds.source}: no torque (tau) columns; identification needs measured joint torques")
    for name in ("dq", "ddq"):
        if getattr(ds, name) is None:
            raise DataError(f"{ds.source}: no {name} columns; differentiate q first (pinid.data.preprocess.prepare, "
                            "which identify() and `pinid identify` call for you)")
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
            raise DataError(f"{ds.source}: {name} of joint '{ds.joints[j]}' has {int(bad[:, j].sum())} NaN or "
                            f"infinite value(s) (first at sample {k}, t = {ds.t[k]:.6g} s); clean or trim the recording")
    return ds


def rest_thresholds(dq: np.ndarray, fraction: float = REST_FRACTION) -> np.ndarray:
    """Per joint: max(fraction·max|dq|, 3·σ̂_v) [rad/s], σ̂_v the velocity noise from the second difference."""
    dq = np.asarray(dq, dtype=float)
    peak = np.max(np.abs(dq), axis=0) if len(dq) else np.zeros(dq.shape[1])
    if len(dq) >= 5:
        d2 = np.diff(dq, 2, axis=0)
        mad = np.median(np.abs(d2 - np.median(d2, axis=0)), axis=0)
        noise = 1.4826 * mad / np.sqrt(6.0)
    else:
        noise = np.zeros(dq.shape[1])
    return np.maximum(fraction * peak, 3.0 * noise)


def rest_threshold(ds: Dataset, model: RobotModel, terms: JointTerms, rest_velocity="auto",
                   rest_fraction: float = REST_FRACTION) -> np.ndarray:
    """Per joint, the speed [rad/s] below which a row of ``ds`` counts as at rest and is left out (zeros
    when Coulomb friction is not in the model or ``rest_velocity`` is 0/None; see the module text)."""
    nv = model.nv
    if not terms.coulomb or rest_velocity is None or (not isinstance(rest_velocity, str) and np.ndim(rest_velocity) == 0
                                                      and float(rest_velocity) == 0.0):
        return np.zeros(nv)
    if isinstance(rest_velocity, str):
        if rest_velocity != "auto":
            raise SpecError(f"rest_velocity={rest_velocity!r}, expected 'auto', a number or one per joint")
        return rest_thresholds(ds.dq, rest_fraction)
    v = np.asarray(rest_velocity, dtype=float).reshape(-1)
    if v.size not in (1, nv):
        raise SpecError(f"rest_velocity={rest_velocity!r}: {v.size} values, expected one or one per joint "
                        f"({nv}: {', '.join(model.joint_names)})")
    v = np.broadcast_to(v, (nv,)).copy()
    if np.any(~np.isfinite(v)) or np.any(v < 0):
        raise SpecError(f"rest_velocity={rest_velocity!r}, expected non-negative numbers [rad/s]")
    return v


def stack_rows(model: RobotModel, terms: JointTerms, base: BaseParameters, datasets: Sequence[Dataset],
               thresholds: Sequence[np.ndarray], *, bar=None) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(W_b, tau, joint, sample)`` of checked recordings stacked row ``k·nv + j``, without the rows whose
    joint speed is below its threshold; ``sample`` counts on across recordings."""
    nv = model.nv
    Ws, taus, joints, samples = [], [], [], []
    offset = 0
    for ds, thr in zip(datasets, thresholds):
        Wb = base_regressor(model, terms, base, ds, bar=bar)
        keep = (np.abs(ds.dq) >= thr).reshape(-1) if np.any(thr > 0) else np.ones(ds.n * nv, bool)
        Ws.append(Wb[keep])
        taus.append(ds.tau.reshape(-1)[keep])
        joints.append(np.tile(np.arange(nv), ds.n)[keep])
        samples.append((offset + np.repeat(np.arange(ds.n), nv))[keep])
        offset += ds.n
    if len(Ws) == 1:
        return Ws[0], taus[0], joints[0], samples[0]
    return np.concatenate(Ws), np.concatenate(taus), np.concatenate(joints), np.concatenate(samples)


def base_regressor(model: RobotModel, terms: JointTerms, base: BaseParameters, ds: Dataset, *, bar=None) -> np.ndarray:
    """Stacked base regressor ``(N·nv, nb)`` of a checked recording, computed in chunks to bound memory."""
    n = ds.n
    out = np.empty((n * model.nv, base.count))
    for start in range(0, n, _CHUNK):
        stop = min(n, start + _CHUNK)
        W = regressor(model, ds.q[start:stop], ds.dq[start:stop], ds.ddq[start:stop], terms)
        np.take(W, base.independent, axis=1, out=out[start * model.nv: stop * model.nv])
        if bar is not None:
            bar.update(stop - start)
    return out


# ====================================================================== results
def _robot_dict(model: RobotModel, terms: JointTerms) -> dict:
    return {"name": model.name, "urdf": None if model.urdf_path is None else str(model.urdf_path),
            "joints": model.joint_names, "locked": dict(model.locked), "terms": terms.names,
            "urdf_text": model.urdf_text}


def _robot_from_dict(d: dict) -> tuple[RobotModel, JointTerms]:
    import tempfile

    terms = JointTerms.from_names(list(d["terms"]))
    text = d.get("urdf_text")
    if text:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "robot.urdf"
            path.write_text(text, encoding="utf-8")
            model = RobotModel.from_urdf(path, joints=d["joints"], locked=d.get("locked") or {})
        model.urdf_path = Path(d["urdf"]) if d.get("urdf") else None
    elif d.get("urdf"):
        model = RobotModel.from_urdf(d["urdf"], joints=d["joints"], locked=d.get("locked") or {})
    else:
        raise SpecError("saved result has no URDF (neither text nor path); cannot rebuild the robot model")
    return model, terms


@dataclass
class IdentificationResult:
    """One method's result.  Arrays follow ``base_names`` / ``standard_names``.

    ``std``: standard deviations of the base parameters, σ² (WᵀW)⁻¹ with σ² = Σ w·r²/(rows − nb) and
    the weights the method used; ``std_percent``: 100·std/|value| (inf for a zero value).
    ``standard``: full standard parameters — the estimator's own (``standard_source = "estimator"``),
    else the physically consistent set closest to the URDF that reproduces the base parameters
    (``"consistent completion"``), else, when none exists, the least-squares completion closest to the
    URDF (``"least-norm completion"``, inconsistent).  Any completion gives the same torques, mass
    matrix, Coriolis and gravity, because those depend on the base parameters only.
    ``physically_consistent``: the check of ``standard`` (:func:`pinid.model.physical.check_consistency`).
    """

    method: str
    base_names: list[str]
    base: np.ndarray
    std: np.ndarray
    standard_names: list[str]
    standard: np.ndarray
    standard_source: str
    physically_consistent: bool
    consistency: dict
    condition_number: float
    train: TorqueMetrics
    seconds: float
    validation: TorqueMetrics | None = None
    settings: dict = field(default_factory=dict)
    description: str = ""
    status: str = "ok"
    info: dict = field(default_factory=dict)
    history: list | None = None
    robot: dict | None = None
    _robot_model: RobotModel | None = field(default=None, repr=False, compare=False)
    _model_cache: object = field(default=None, repr=False, compare=False)

    @property
    def std_percent(self) -> np.ndarray:
        """Relative standard deviations [%]."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return 100.0 * self.std / np.abs(self.base)

    @property
    def residual_rms(self) -> dict[str, float]:
        """Training residual RMS per joint [N·m]."""
        return {j: m["rms"] for j, m in self.train.per_joint.items()}

    @property
    def base_parameters(self) -> dict[str, float]:
        """``{name: value}`` of the base parameters."""
        return dict(zip(self.base_names, map(float, self.base)))

    @property
    def standard_parameters(self) -> dict[str, float]:
        """``{name: value}`` of the standard parameters."""
        return dict(zip(self.standard_names, map(float, self.standard)))

    @property
    def robot_model(self) -> RobotModel:
        """The (nominal) RobotModel this result belongs to, rebuilt from the saved URDF text if needed."""
        if self._robot_model is None:
            if not self.robot:
                raise SpecError("result has no robot description; cannot build its model")
            self._robot_model, _ = _robot_from_dict(self.robot)
        return self._robot_model

    @property
    def model(self):
        """The :class:`~pinid.identification.identified.IdentifiedModel` with these parameters (built once)."""
        if self._model_cache is None:
            from pinid.identification.identified import IdentifiedModel

            terms = JointTerms.from_names(self.robot["terms"]) if self.robot else None
            self._model_cache = IdentifiedModel(
                self.robot_model, terms, self.standard, physically_consistent=self.physically_consistent,
                meta={"method": self.method, "standard_source": self.standard_source})
        return self._model_cache

    def export_urdf(self, path: str | os.PathLike | None = None, *, force: bool = False) -> str:
        """The identified URDF (see :func:`pinid.model.export.identified_urdf`); written to ``path`` when given."""
        from pinid.model.export import identified_urdf

        return identified_urdf(self.robot_model, self.standard, JointTerms.from_names(self.robot["terms"]), path,
                               force=force, comment=f"method {self.method}")

    def to_dict(self, *, include_robot: bool = True) -> dict:
        """Plain-dict form (the entry of ``identification.json`` under ``methods``)."""
        d = {
            "method": self.method,
            "description": self.description,
            "settings": {k: (v if isinstance(v, (int, float, str, bool, type(None), dict, list, tuple)) else repr(v))
                         for k, v in self.settings.items()},
            "status": self.status,
            "base_parameters": self.base_parameters,
            "std": dict(zip(self.base_names, map(float, self.std))),
            "std_percent": dict(zip(self.base_names, map(float, self.std_percent))),
            "standard_parameters": self.standard_parameters,
            "standard_source": self.standard_source,
            "physically_consistent": bool(self.physically_consistent),
            "consistency": self.consistency,
            "condition_number": self.condition_number,
            "residual_rms": self.residual_rms,
            "train": self.train.to_dict(),
            "validation": None if self.validation is None else self.validation.to_dict(),
            "seconds": self.seconds,
            "info": self.info,
            "history": self.history,
        }
        if include_robot:
            d["robot"] = self.robot
        return jsonable(d)

    @classmethod
    def from_dict(cls, d: dict, *, robot: dict | None = None) -> "IdentificationResult":
        """Inverse of :meth:`to_dict` (``robot``: the description when stored separately)."""
        base_names = list(d["base_parameters"])
        std_names = list(d["standard_parameters"])
        num = (lambda v: float("nan") if v is None else float(v))
        return cls(
            method=d["method"], base_names=base_names,
            base=np.array([num(d["base_parameters"][n]) for n in base_names]),
            std=np.array([num(d["std"][n]) for n in base_names]),
            standard_names=std_names, standard=np.array([num(d["standard_parameters"][n]) for n in std_names]),
            standard_source=d["standard_source"], physically_consistent=bool(d["physically_consistent"]),
            consistency=d.get("consistency") or {}, condition_number=num(d["condition_number"]),
            train=TorqueMetrics.from_dict(d["train"]), seconds=float(d["seconds"]),
            validation=None if d.get("validation") is None else TorqueMetrics.from_dict(d["validation"]),
            settings=d.get("settings") or {}, description=d.get("description", ""), status=d.get("status", "ok"),
            info=d.get("info") or {}, history=d.get("history"), robot=robot if robot is not None else d.get("robot"),
        )

    def save(self, path: str | os.PathLike) -> Path:
        """Write as JSON (atomically), with the robot's URDF text so that :meth:`load` needs nothing else."""
        from pinid.io import write_json

        return write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | os.PathLike) -> "IdentificationResult":
        """Read a JSON file written by :meth:`save`."""
        return cls.from_dict(read_json(path, "identification result"))


@dataclass
class Identification:
    """Results of several methods on the same data (what :func:`identify` returns).

    ``results[method]`` is an :class:`IdentificationResult`; ``best`` names the one ``model`` uses: the
    physically consistent result with the lowest validation RMS (training RMS without validation); if
    none is consistent, the lowest RMS.  ``curves`` keeps the torque traces for plots (not saved).
    """

    robot: dict
    results: dict[str, IdentificationResult]
    data: dict
    base: dict
    validation_sources: list[str] = field(default_factory=list)
    seconds: float = 0.0
    curves: dict = field(default_factory=dict, repr=False, compare=False)

    def __getitem__(self, method: str) -> IdentificationResult:
        try:
            return self.results[method]
        except KeyError:
            raise SpecError(f"no result for method '{method}' (methods run: {', '.join(self.results)})") from None

    def __iter__(self):
        return iter(self.results.values())

    @property
    def best(self) -> str:
        """Name of the preferred result (see the class text).  Results within 0.1 % of the lowest RMS
        count as equal; among those, one whose standard parameters come from the estimator itself (the
        LMI method) wins, then the first in the order run."""
        def score(r: IdentificationResult) -> float:
            m = r.validation if r.validation is not None else r.train
            v = m.all["rms"]
            return v if np.isfinite(v) else np.inf

        pool = [r for r in self.results.values() if r.physically_consistent] or list(self.results.values())
        low = min(score(r) for r in pool)
        close = [r for r in pool if score(r) <= low * 1.001 or score(r) == low]
        close.sort(key=lambda r: 0 if r.standard_source == "estimator" else 1)
        return close[0].method

    @property
    def model(self):
        """The :class:`~pinid.identification.identified.IdentifiedModel` of the best result."""
        return self.results[self.best].model

    def to_dict(self) -> dict:
        """The content of ``identification.json``."""
        from pinid import __version__

        return jsonable({
            "pinid_version": __version__,
            "robot": self.robot,
            "data": self.data,
            "validation_sources": self.validation_sources,
            "base": self.base,
            "best": self.best if self.results else None,
            "seconds": self.seconds,
            "methods": {m: r.to_dict(include_robot=False) for m, r in self.results.items()},
        })

    @classmethod
    def from_dict(cls, d: dict) -> "Identification":
        """Rebuild from :meth:`to_dict`'s output (a loaded ``identification.json``)."""
        robot = d["robot"]
        results = {m: IdentificationResult.from_dict(r, robot=robot) for m, r in d["methods"].items()}
        return cls(robot, results, d.get("data") or {}, d.get("base") or {}, list(d.get("validation_sources") or []),
                   float(d.get("seconds") or 0.0))

    def save(self, path: str | os.PathLike) -> Path:
        """Write ``identification.json`` (atomically)."""
        from pinid.io import write_json

        return write_json(path, self.to_dict())

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Identification":
        """Read a file written by :meth:`save` (or ``pinid identify``)."""
        d = read_json(path, "identification")
        if "methods" not in d or "robot" not in d:
            raise SpecError(f"{path}: not an identification file (no 'methods' or 'robot')")
        return cls.from_dict(d)


# ====================================================================== statistics
def base_statistics(problem: IdentificationProblem, base: np.ndarray, weights: np.ndarray | None = None
                    ) -> tuple[np.ndarray, float, float]:
    """``(std, condition_number, condition_number_scaled)`` of base parameters fitted with row ``weights``.

    σ² = Σ w·r² / (rows − nb), cov = σ²·(Wᵀ diag(w) W)⁻¹; the condition numbers are those of
    diag(√w)·W as it is and with unit-norm columns.
    """
    import scipy.linalg

    w = problem.weights if weights is None else weights
    r = problem.tau - problem.W @ base
    dof = max(problem.rows - problem.nb, 1)
    sigma2 = float(np.sum(w * r * r)) / dof
    R, _, _, scale = problem.compressed(weights)
    try:
        Rinv = scipy.linalg.solve_triangular(R, np.eye(len(R)))
        std = np.sqrt(sigma2 * np.sum(Rinv**2, axis=1)) / scale
    except (np.linalg.LinAlgError, ValueError):
        std = np.full(problem.nb, np.inf)
    s_scaled = np.linalg.svd(R, compute_uv=False)
    s_raw = np.linalg.svd(R * scale, compute_uv=False)
    cond = float(s_raw[0] / s_raw[-1]) if s_raw[-1] > 0 else float("inf")
    cond_scaled = float(s_scaled[0] / s_scaled[-1]) if s_scaled[-1] > 0 else float("inf")
    return std, cond, cond_scaled


def least_norm_completion(problem: IdentificationProblem, base: np.ndarray) -> np.ndarray:
    """The standard vector closest to the nominal one (in the scaled norm) with ``P·θ = base``."""
    from pinid.model.physical import parameter_scale

    S = parameter_scale(problem.nominal, problem.nv, len(problem.terms))
    A = problem.base.P * S
    z0 = problem.nominal / S
    dz = np.linalg.lstsq(A, base - A @ z0, rcond=None)[0]
    return (z0 + dz) * S


def make_result(problem: IdentificationProblem, estimator, seconds: float, *, complete: bool = True
                ) -> IdentificationResult:
    """Check a fitted estimator and wrap it as an :class:`IdentificationResult` (training metrics included)."""
    from pinid.model.physical import check_consistency

    base = np.asarray(estimator.base_, dtype=float)
    if base.shape != (problem.nb,):
        raise PinidError(f"{estimator.name}: base_ has shape {base.shape}, expected ({problem.nb},)")
    info = dict(getattr(estimator, "info_", {}) or {})
    std_names = problem.standard_names
    theta = getattr(estimator, "standard_", None)
    if not np.all(np.isfinite(base)):
        raise PinidError(f"{estimator.name}: the estimate has NaN or infinite values")
    if theta is not None:
        theta = np.asarray(theta, dtype=float)
        source = "estimator"
        mismatch = np.abs(problem.base.P @ theta - base).max() / max(np.abs(base).max(), 1e-300)
        if mismatch > 1e-6:
            info["standard_base_mismatch"] = float(mismatch)
    else:
        source = None
        if complete:
            from pinid.estimators.sdp import consistent_completion

            t0 = time.perf_counter()
            theta, why = consistent_completion(problem, base)
            info["completion_seconds"] = time.perf_counter() - t0
            if theta is not None:
                source = "consistent completion"
            else:
                info["not_realisable"] = why
        if theta is None:
            theta = least_norm_completion(problem, base)
            source = "least-norm completion"
    report = check_consistency(theta, problem.model.joint_names, problem.terms.names, problem.model.motor_names)
    consistent = report.consistent and "standard_base_mismatch" not in info
    w = getattr(estimator, "weights_", None)
    std, cond, cond_scaled = base_statistics(problem, base, w)
    info["condition_number_scaled"] = cond_scaled
    train = torque_metrics(problem.tau, problem.W @ base, problem.model.joint_names, problem.joint)
    return IdentificationResult(
        method=estimator.name, base_names=problem.names, base=base, std=std, standard_names=std_names,
        standard=theta, standard_source=source, physically_consistent=bool(consistent),
        consistency=report.to_dict(), condition_number=cond, train=train, seconds=float(seconds),
        settings=estimator.get_params(), description=estimator.description,
        status=str(getattr(estimator, "status_", "ok")), info=info, history=getattr(estimator, "history_", None),
        robot=_robot_dict(problem.model, problem.terms), _robot_model=problem.model,
    )


# ====================================================================== the API
def _load_data(items, model: RobotModel, mapping, preprocess, what: str) -> list[Dataset]:
    if items is None:
        return []
    if isinstance(items, (Dataset, str, os.PathLike)):
        items = [items]
    out = []
    for item in items:
        if isinstance(item, Dataset):
            ds = item
        else:
            try:
                from pinid.data.formats import read_recording
            except ImportError:
                raise DataError(f"{item}: reading recordings needs pinid.data.formats, which is not available") from None
            ds = read_recording(item, mapping=mapping, model=model)
        out.append(prepare_dataset(ds, preprocess))
    if not out:
        raise DataError(f"no {what} recording given")
    return out


def prepare_dataset(ds: Dataset, preprocess: Mapping | bool | None = None) -> Dataset:
    """Fill ``dq`` and ``ddq`` when missing (pinid.data.preprocess.prepare with defaults from the sample rate).

    ``preprocess``: None — prepare only recordings without ``dq`` or ``ddq``; a dict — always prepare,
    with these options (``cutoff``, ``preset``, ``differentiation``, ``trim`` …); False — never.
    """
    needs = ds.dq is None or ds.ddq is None
    if preprocess is False or (preprocess is None and not needs):
        return ds
    try:
        from pinid.data.preprocess import prepare
    except ImportError:
        missing = [n for n in ("dq", "ddq") if getattr(ds, n) is None]
        raise DataError(f"{ds.source}: no {'/'.join(missing)} columns, and pinid.data.preprocess (which differentiates q) "
                        "is not available") from None
    return prepare(ds, **dict(preprocess or {}))


def predict_torque(model: RobotModel, terms: JointTerms, base: BaseParameters, ds: Dataset,
                   values: np.ndarray | Mapping[str, np.ndarray]):
    """Predicted torques ``(N, nv)`` [N·m] on a checked recording for base ``values`` (or a dict of them)."""
    ds = check_dataset(ds, model)
    Wb = base_regressor(model, terms, base, ds)
    if isinstance(values, Mapping):
        return {k: (Wb @ v).reshape(ds.n, model.nv) for k, v in values.items()}
    return (Wb @ values).reshape(ds.n, model.nv)


def identify(
    model: RobotModel | str | os.PathLike,
    data: Dataset | str | os.PathLike | Iterable,
    *,
    methods: Sequence[str] | str = DEFAULT_METHODS,
    validate: Dataset | str | os.PathLike | Iterable | None = None,
    terms: JointTerms | str = JointTerms(),
    mapping=None,
    preprocess: Mapping | bool | None = None,
    rest_velocity: float | Sequence[float] | str | None = "auto",
    rest_fraction: float = REST_FRACTION,
    options: Mapping[str, Mapping] | None = None,
    complete: bool = True,
    show_progress: bool | None = False,
) -> Identification:
    """Identify ``model``'s dynamic parameters from recordings with several methods; validate; compare.

    ``model``: a RobotModel, URDF path or robot name.  ``data`` / ``validate``: Datasets or recording
    paths (read with :func:`pinid.data.formats.read_recording` and ``mapping``).  Recordings without ``dq`` or
    ``ddq`` go through :func:`pinid.data.preprocess.prepare` (see :func:`prepare_dataset` for ``preprocess``).
    ``methods``: names from :data:`pinid.estimators.ESTIMATORS` (default ols, wls, sdp).  ``terms``: the
    joint terms in the model (default Coulomb and viscous friction).  ``rest_velocity``,
    ``rest_fraction``: rows at rest dropped for Coulomb friction (module text).  ``options``: settings
    per method, e.g. ``{"sdp": {"regularization": 1e-2, "mass_bounds": (0.1, 20)}}``.  ``complete``:
    look for a consistent standard set behind base-only results (one small SDP each).

    Returns an :class:`Identification`; ``result.model`` is the best result's
    :class:`~pinid.identification.identified.IdentifiedModel`, ``result["sdp"]`` one method's result.
    """
    from pinid.estimators import make_estimator
    from pinid.progress import progress

    t_start = time.perf_counter()
    if not isinstance(model, RobotModel):
        model = RobotModel.from_urdf(model)
    if isinstance(terms, str):
        try:
            terms = JointTerms.from_names(terms)
        except ValueError as exc:
            raise SpecError(str(exc)) from None
    if isinstance(methods, str):
        methods = [m.strip() for m in methods.split(",") if m.strip()]
    methods = list(dict.fromkeys(m.lower() for m in methods))
    if not methods:
        raise SpecError("no method given, expected some of ols, wls, sdp")
    options = dict(options or {})
    estimators = {m: make_estimator(m, **dict(options.get(m, {}))) for m in methods}
    unknown = [k for k in options if k not in estimators]
    if unknown:
        raise SpecError(f"options for method(s) {unknown} that are not run (methods: {', '.join(methods)})")
    train_sets = _load_data(data, model, mapping, preprocess, "training")
    val_sets = _load_data(validate, model, mapping, preprocess, "validation") if validate is not None else []
    base = base_parameters(model, terms)
    problem = IdentificationProblem.from_datasets(model, train_sets, terms=terms, base=base,
                                                  rest_velocity=rest_velocity, rest_fraction=rest_fraction,
                                                  show_progress=show_progress)
    results: dict[str, IdentificationResult] = {}
    bar = progress(len(methods), "methods", enabled=show_progress)
    try:
        for m, est in estimators.items():
            bar.set_description(m)
            problem.__dict__.pop("_compressed", None)  # each method's time includes its QR compression
            t0 = time.perf_counter()
            est.fit(problem)
            seconds = time.perf_counter() - t0
            results[m] = make_result(problem, est, seconds, complete=complete)
            bar.update(1)
    finally:
        bar.close()
    curves = {}
    if val_sets:
        checked = [check_dataset(ds, model) for ds in val_sets]
        preds = {m: [] for m in results}
        for ds in checked:
            p = predict_torque(model, terms, base, ds, {m: r.base for m, r in results.items()})
            for m in results:
                preds[m].append(p[m])
        tau_all = np.concatenate([ds.tau for ds in checked])
        for m, r in results.items():
            r.validation = torque_metrics(tau_all, np.concatenate(preds[m]), model.joint_names)
        first = checked[0]
        curves = {"kind": "validation", "source": first.source, "t": first.t, "measured": first.tau,
                  "predicted": {m: preds[m][0] for m in results}}
    else:
        ds = check_dataset(train_sets[0], model)
        curves = {"kind": "training", "source": ds.source, "t": ds.t, "measured": ds.tau,
                  "predicted": predict_torque(model, terms, base, ds, {m: r.base for m, r in results.items()})}
    return Identification(
        robot=_robot_dict(model, terms), results=results, data=problem.summary(),
        base={"names": base.names, "expressions": base.expressions(), "nominal": base.from_standard(problem.nominal).tolist()},
        validation_sources=[ds.source for ds in val_sets], seconds=time.perf_counter() - t_start, curves=curves,
    )
