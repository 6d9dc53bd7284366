"""Seed 000's segmental identification strategy (§3.1, Fig. 5, Eq. (9)), for any estimator.

A base vibrates more when the whole leg swings than when the shank alone does, so seed 000 identifies
the leg in two stages:

1. **First stage** — the hip is held fixed and the knee swings (its Table 1 trajectories 1 and 2).  The
   knee's parameters X(6:10) (= pinid's base parameters named ``knee.*``) are identified from the
   knee's torque rows only.
2. **Subtraction** — hip and knee swing together (trajectories 3 and 4).  The part of the hip's torque
   due to the knee's parameters, ``T₁² = H_h(6:10)·X(6:10)`` (Eq. (9)), is computed with the first
   stage's values and subtracted: ``T₁' = T₁ − T₁²``.
3. **Second stage** — the hip's parameters X(1:5) (``hip.*``) are identified from ``T₁'`` and the hip's
   rows of the regressor.

In pinid's terms: the base parameters are split into the *first group* (those named after the
``first_joints``, default ``("knee",)``) and the rest; the first stage uses the rows of the first
joints in the ``first`` recordings and the columns of the first group; the second stage the rows of the
other joints in the ``second`` recordings, the columns of the other group, and the torques minus the
first group's contribution.  It needs the first joints' torques not to depend on the other group's
parameters — true when the first joints are the distal ones of a serial chain (checked).

Every estimator of :data:`pinid.estimators.ESTIMATORS` works on the stages' sub-problems
(:class:`SubProblem`), except those that fit the full standard parameters (``fits_standard``: the LMI
method), which run each stage themselves (``fit_stage``): stage one finds a physically consistent θ whose first-group
base parameters fit the first joints' rows; stage two a consistent θ whose first-group base parameters
*equal* the first stage's and whose others fit the second rows — so the final θ is consistent and
reproduces both stages.

The combined base vector is wrapped by :func:`pinid.identification.result.make_result` on the second
recordings' full problem (standard deviations, consistency check or completion, training metrics
over both joints of the second recordings).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from collections.abc import Sequence

import numpy as np

from pinid.model.base import BaseParameters, base_parameters
from pinid.data.dataset import Dataset
from pinid.errors import DataError, SpecError
from pinid.estimators import ESTIMATORS, make_estimator
from pinid.estimators.base import Estimator
from pinid.problem.cache import ProblemCache
from pinid.problem.problem import REST_FRACTION, IdentificationProblem, check_dataset, stack_rows
from pinid.problem.recordings import load_datasets
from pinid.problem.rows import rest_threshold
from pinid.identification.result import IdentificationResult, make_result
from pinid.linalg import augmented_r
from pinid.model.robot import RobotModel
from pinid.model.physical import parameter_scale
from pinid.model.regressor import standard_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import as_robot


# ============================================================================================ sub-problems
@dataclass
class SubProblem:
    """Some rows and some base-parameter columns of a stacked problem, with a known torque subtracted.

    It is a :class:`~pinid.problem.problem.Problem` (what base-only estimators use: ``W``, ``tau``,
    ``weights``, ``joint``, ``sample``, ``nb``, ``nv``, ``rows``, ``names``, ``nominal_base``,
    ``natural_scale``, ``compressed()``, ``model``, ``terms``), without ``base`` (the map to standard
    parameters belongs to the full problem).
    """

    model: RobotModel
    terms: TermSelection
    W: np.ndarray
    tau: np.ndarray
    joint: np.ndarray
    sample: np.ndarray
    weights: np.ndarray
    names: list[str]
    nominal_base: np.ndarray
    natural_scale: np.ndarray
    columns: np.ndarray
    sources: list[str] = field(default_factory=list)
    cache: ProblemCache = field(default_factory=ProblemCache, init=False, repr=False, compare=False)

    @property
    def nb(self) -> int:
        """Number of base parameters."""
        return self.W.shape[1]

    @property
    def nv(self) -> int:
        """Number of joints."""
        return self.model.nv

    @property
    def rows(self) -> int:
        """Number of torque rows."""
        return len(self.tau)

    def compressed(self, weights: np.ndarray | None = None):
        """``(R, c, rho, scale)`` of :func:`pinid.linalg.augmented_r`, cached for the own weights."""
        if weights is not None and weights is not self.weights:
            return augmented_r(self.W, self.tau, weights)
        kept = self.cache.get("compressed")
        if kept is None:
            kept = self.cache.put("compressed", augmented_r(self.W, self.tau, self.weights))
        return kept


def _natural_scale(model: RobotModel, terms: TermSelection, base: BaseParameters) -> np.ndarray:
    return np.abs(base.P) @ parameter_scale(standard_parameters(model, terms), model.nv, len(terms))


def _stack(
    model: RobotModel,
    datasets: Dataset | Sequence[Dataset],
    terms: TermSelection,
    base: BaseParameters,
    *,
    rest_velocity="auto",
    rest_fraction: float = REST_FRACTION,
) -> dict:
    """Stacked base regressor of recordings *without* the rank check (a joint held fixed is allowed).

    Returns ``{"W", "tau", "joint", "sample", "sources"}``; rows of a joint at rest are dropped when
    Coulomb friction is in the model, as :meth:`IdentificationProblem.from_datasets` does.
    """
    model = as_robot(model)
    if isinstance(datasets, Dataset):
        datasets = [datasets]
    datasets = [check_dataset(ds, model) for ds in datasets]
    if not datasets:
        raise DataError("no recording given for a stage of the segmental identification")
    thresholds = [rest_threshold(ds, model, terms, rest_velocity, rest_fraction) for ds in datasets]
    W, tau, joint, sample = stack_rows(
        model, terms, base, datasets, thresholds, rest_velocity=rest_velocity, rest_fraction=rest_fraction
    )
    return {"W": W, "tau": tau, "joint": joint, "sample": sample, "sources": [ds.source for ds in datasets]}


# ============================================================================================ the problem
class SegmentalProblem:
    """The two stages of seed 000's segmental strategy on given recordings (module text).

    ``first``: recordings with the other joints held fixed (seed 000: hip fixed, knee swinging);
    ``second``: recordings with every joint moving; ``first_joints``: the joints identified first.
    ``problem`` is the full :class:`~pinid.problem.problem.IdentificationProblem` of ``second`` (what the
    result is reported on); ``first_problem`` the first stage's :class:`SubProblem`.
    """

    def __init__(
        self,
        model: RobotModel,
        first,
        second,
        *,
        first_joints: Sequence[str] = ("knee",),
        terms: TermSelection = TermSelection(),
        rest_velocity="auto",
        rest_fraction: float = REST_FRACTION,
        base: BaseParameters | None = None,
    ) -> None:
        self.model, self.terms = model, terms
        self.base = base if base is not None else base_parameters(model, terms)
        self.first_joints = [str(j) for j in first_joints]
        for j in self.first_joints:
            model.joint_index(j)  # JointError for unknown joints
        names = self.base.names
        in_first = np.array([n.split(".", 1)[0] in self.first_joints for n in names])
        if not in_first.any():
            raise SpecError(
                f"segmental: no base parameter belongs to joint(s) {', '.join(self.first_joints)} "
                f"(base parameters: {', '.join(names)})"
            )
        if in_first.all():
            raise SpecError(
                "segmental: every base parameter belongs to the first joints; nothing is left for the second stage"
            )
        self.first_cols = np.flatnonzero(in_first)
        self.second_cols = np.flatnonzero(~in_first)
        self.first_rows_joints = np.array([model.joint_index(j) for j in self.first_joints])
        self.scale = _natural_scale(model, terms, self.base)
        self.problem = IdentificationProblem.from_datasets(
            model, second, terms=terms, base=self.base, rest_velocity=rest_velocity, rest_fraction=rest_fraction
        )
        s1 = _stack(model, first, terms, self.base, rest_velocity=rest_velocity, rest_fraction=rest_fraction)
        rows1 = np.isin(s1["joint"], self.first_rows_joints)
        W1 = s1["W"][rows1]
        leak = np.linalg.norm(W1[:, self.second_cols]) if self.second_cols.size else 0.0
        if leak > 1e-9 * max(np.linalg.norm(W1[:, self.first_cols]), 1e-300):
            raise SpecError(
                f"segmental: the torques of {', '.join(self.first_joints)} depend on parameters of other "
                "joints; identify the distal joints first (seed 000: the knee)"
            )
        nominal_base = self.base.from_standard(standard_parameters(model, terms))
        self.nominal_base = nominal_base
        self.first_problem = SubProblem(
            model,
            terms,
            W1[:, self.first_cols],
            s1["tau"][rows1],
            s1["joint"][rows1],
            s1["sample"][rows1],
            np.ones(int(rows1.sum())),
            [names[i] for i in self.first_cols],
            nominal_base[self.first_cols],
            self.scale[self.first_cols],
            self.first_cols,
            sources=s1["sources"],
        )
        if self.first_problem.rows <= self.first_problem.nb:
            raise DataError(
                f"{', '.join(s1['sources'])}: {self.first_problem.rows} torque rows of "
                f"{', '.join(self.first_joints)} for {self.first_problem.nb} parameters"
            )
        p = self.problem
        self._rows2 = ~np.isin(p.joint, self.first_rows_joints)

    @property
    def names(self) -> list[str]:
        """Names of the base parameters."""
        return list(self.base.names)

    def second_problem(self, x_first: np.ndarray) -> SubProblem:
        """The second stage's sub-problem: the other joints' rows, torques minus Eq. (9)'s ``T₁²``."""
        p = self.problem
        rows = self._rows2
        W = p.W[rows]
        tau = p.tau[rows] - W[:, self.first_cols] @ np.asarray(x_first, float)
        names = self.base.names
        return SubProblem(
            self.model,
            self.terms,
            np.ascontiguousarray(W[:, self.second_cols]),
            tau,
            p.joint[rows],
            p.sample[rows],
            p.weights[rows],
            [names[i] for i in self.second_cols],
            self.nominal_base[self.second_cols],
            self.scale[self.second_cols],
            self.second_cols,
            sources=list(p.sources),
        )

    def combine(self, x_first: np.ndarray, x_second: np.ndarray) -> np.ndarray:
        """The full base vector from the two groups."""
        x = np.empty(self.base.count)
        x[self.first_cols] = x_first
        x[self.second_cols] = x_second
        return x


# ============================================================================================ estimator
class Segmental(Estimator):
    """An estimator of the registry run in seed 000's two stages: ``fit(SegmentalProblem) -> self``.

    ``method``: a name of :data:`pinid.estimators.ESTIMATORS`; ``settings``: its settings (the same in
    both stages).  Fitted: ``base_`` (both groups), ``standard_`` (LMI method only), ``stages_`` (each
    stage's estimator), ``history_`` (the second stage's), ``info_["segmental"]``.
    """

    def __init__(self, method: str = "ols", settings: dict | None = None) -> None:
        self.method = method
        self.settings = settings

    @property
    def name(self) -> str:  # type: ignore[override]
        return self.method

    @property
    def description(self) -> str:  # type: ignore[override]
        cls = ESTIMATORS.get(self.method)
        return f"{cls.description if cls else self.method} — segmental (seed 000 §3.1)"

    def get_params(self) -> dict:
        return {"method": self.method, "segmental": True, **dict(self.settings or {})}

    def fit(self, seg: SegmentalProblem) -> "Segmental":
        """Identify the ``first_joints``' parameters on the ``first`` recordings, subtract their torque from the
        ``second`` recordings, then identify the rest there (seed 000 §3.1); sets ``base_``."""
        if not isinstance(seg, SegmentalProblem):
            raise SpecError("Segmental.fit expects a SegmentalProblem")
        settings = dict(self.settings or {})
        t0 = time.perf_counter()
        if ESTIMATORS[self.method].fits_standard:  # stages on the full standard parameters (the LMI method)
            est = make_estimator(self.method, **settings)
            theta1, info1 = est.fit_stage(seg.problem, seg.first_problem, seg.first_cols, what="segmental sdp stage 1")
            x1 = (seg.base.P @ theta1)[seg.first_cols]
            t1 = time.perf_counter()
            theta, info2 = est.fit_stage(
                seg.problem,
                seg.second_problem(x1),
                seg.second_cols,
                fixed=(seg.first_cols, x1),
                what="segmental sdp stage 2",
            )
            x = seg.base.P @ theta
            x[seg.first_cols] = x1  # equal to the solver's precision; keep the first stage's exact values
            self.standard_ = theta
            self.stages_ = (None, None)
            self.history_ = None
            self.status_ = info2.get("status", "ok")
            stage_info = ({"seconds": t1 - t0, **info1}, {"seconds": time.perf_counter() - t1, **info2})
        else:
            e1 = make_estimator(self.method, **settings).fit(seg.first_problem)
            x1 = np.asarray(e1.base_, float)
            t1 = time.perf_counter()
            e2 = make_estimator(self.method, **settings).fit(seg.second_problem(x1))
            x = seg.combine(x1, np.asarray(e2.base_, float))
            self.standard_ = None
            self.stages_ = (e1, e2)
            self.history_ = e2.history_
            self.status_ = getattr(e2, "status_", "ok")
            stage_info = (
                {"seconds": t1 - t0, "history": e1.history_, **_json_info(e1.info_)},
                {"seconds": time.perf_counter() - t1, **_json_info(e2.info_)},
            )
        self.base_ = x
        self.weights_ = None
        self.info_ = {
            "segmental": {
                "first_joints": seg.first_joints,
                "first_parameters": [seg.names[i] for i in seg.first_cols],
                "second_parameters": [seg.names[i] for i in seg.second_cols],
                "first_sources": seg.first_problem.sources,
                "first_rows": seg.first_problem.rows,
                "second_rows": int(seg._rows2.sum()),
                "first_stage": stage_info[0],
                "second_stage": stage_info[1],
            }
        }
        return self


def _json_info(info: dict | None) -> dict:
    return {k: v for k, v in dict(info or {}).items() if k not in ("history",)}


# ============================================================================================ the API
def segmental_identify(
    model: RobotModel | str,
    first,
    second,
    *,
    method: str = "ols",
    first_joints: Sequence[str] = ("knee",),
    settings: dict | None = None,
    terms: TermSelection = TermSelection(),
    rest_velocity="auto",
    preprocess=None,
    complete: bool = True,
) -> IdentificationResult:
    """Seed 000's segmental identification with one estimator; returns an :class:`IdentificationResult`.

    ``first``: recording(s) with only ``first_joints`` moving (seed 000: trajectory 1, hip fixed);
    ``second``: recording(s) with every joint moving (trajectory 3).  Recordings without ``dq``/``ddq``
    are prepared (:func:`pinid.problem.recordings.prepare_dataset`).  The result's training metrics are over
    the second recordings' rows (both joints); ``info["segmental"]`` describes the stages.
    """
    if not isinstance(model, RobotModel):
        model = RobotModel.from_urdf(model)
    first_sets = load_datasets(first, model, None, preprocess, "first-stage")
    second_sets = load_datasets(second, model, None, preprocess, "second-stage")
    seg = SegmentalProblem(
        model, first_sets, second_sets, first_joints=first_joints, terms=terms, rest_velocity=rest_velocity
    )
    est = Segmental(method, settings)
    t0 = time.perf_counter()
    est.fit(seg)
    return make_result(seg.problem, est, time.perf_counter() - t0, complete=complete)
