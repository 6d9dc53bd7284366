"""Identification results: one method's (:class:`IdentificationResult`), several methods' on the same data
(:class:`Identification`), their JSON, and :func:`make_result`, which checks a fitted estimator and wraps it.
"""

from __future__ import annotations

import os
import time
from dataclasses import asdict, dataclass, field, is_dataclass
from pathlib import Path

import numpy as np

from pinid.errors import PinidError, SpecError
from pinid.identification.identified import IdentifiedModel
from pinid.identification.metrics import TorqueMetrics, error_metrics, joint_units, torque_metrics
from pinid.identification.uncertainty import uncertainty_warning
from pinid.problem.problem import IdentificationProblem
from pinid.problem.statistics import base_statistics, least_norm_completion
from pinid.io import display_path, jsonable, read_json
from pinid.model.base import MARKS
from pinid.model.lmi import consistent_completion
from pinid.model.physical import check_consistency
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel
from pinid.model.serialize import robot_from_dict, robot_to_dict
from pinid.result_protocol import ResultProtocol

#: A constrained estimate (sdp) whose value is within this fraction of its natural scale of zero sits on a
#: bound (friction ≥ 0, a pseudo-inertia margin): its σ is not that of a free parameter and is not printed.
BOUND_FRACTION = 1e-6


@dataclass
class IdentificationResult(ResultProtocol):
    """One method's result.  Arrays follow ``base_names`` / ``standard_names``.

    ``std``: standard deviations of the base parameters, the Newey–West sandwich of
    :func:`~pinid.problem.statistics.base_statistics` with the weights the method used; NaN (JSON null,
    printed "—") where no calibrated σ exists (metaheuristics; an sdp value on a bound);
    ``std_percent``: 100·std/|value| (inf for a zero value).
    ``standard``: full standard parameters — the estimator's own (``standard_source = "estimator"``),
    else the physically consistent set closest to the URDF that reproduces the base parameters
    (``"consistent completion"``), else, when none exists, the least-squares completion closest to the
    URDF (``"least-norm completion"``, inconsistent).  Any completion gives the same torques, mass
    matrix, Coriolis and gravity, because those depend on the base parameters only.
    ``physically_consistent``: the check of ``standard`` (:func:`pinid.model.physical.check_consistency`).
    ``train``, ``validation``: torque errors against the torque **as recorded** (the fixed yardstick,
    :func:`pinid.problem.problem.recorded_torque`); ``train_filtered``, ``validation_filtered``:
    the same against the torque after pinid's own preprocessing (low-pass), which moves with ``--cutoff``.
    ``truth_error``: ``{"names", "truth", "error", "error_percent"}`` against a known truth
    (:func:`truth_errors`), None without one.  ``marks``: ``{standard name: "identified" | "partly" |
    "not identified"}`` (:meth:`pinid.model.base.BaseParameters.marks`): which standard values the data
    determined and which are the completion's prior (the URDF's) carried through; None when unknown.
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
    train_filtered: TorqueMetrics | None = None
    validation_filtered: TorqueMetrics | None = None
    truth_error: dict | None = None
    marks: dict[str, str] | None = None
    _robot_model: RobotModel | None = field(default=None, repr=False, compare=False)
    _model_cache: object = field(default=None, repr=False, compare=False)

    PLOTS = {"validation": False, "train": False}
    FILE_KIND = "identification result"

    @property
    def std_percent(self) -> np.ndarray:
        """Relative standard deviations [%]."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return 100.0 * self.std / np.abs(self.base)

    @property
    def warning(self) -> str | None:
        """One line when the data determine the parameters poorly (:mod:`pinid.identification.uncertainty`)."""
        robot = self.robot or {}
        urdf = robot.get("urdf")
        bundled = urdf and Path(urdf).parent.name == "urdf" and Path(urdf).parent.parent.name == "resources"
        where = robot.get("name") if bundled or not urdf else display_path(urdf)
        return uncertainty_warning(self, robot.get("terms"), where)

    @property
    def residual_rms(self) -> dict[str, float]:
        """Training residual RMS per joint [N·m]: the fit's own residual (against the preprocessed torque)."""
        m = self.train_filtered if self.train_filtered is not None else self.train
        return {j: v["rms"] for j, v in m.per_joint.items()}

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
            self._robot_model, _ = robot_from_dict(self.robot)
        return self._robot_model

    @property
    def model(self):
        """The :class:`~pinid.identification.identified.IdentifiedModel` with these parameters (built once)."""
        if self._model_cache is None:
            terms = TermSelection.from_names(self.robot["terms"]) if self.robot else None
            self._model_cache = IdentifiedModel(
                self.robot_model,
                terms,
                self.standard,
                physically_consistent=None if self.physically_consistent else False,  # None: checked again
                meta={"method": self.method, "standard_source": self.standard_source}
                | ({} if self.marks is None else {"standard_marks": dict(self.marks)}),
            )
        return self._model_cache

    def export_urdf(self, path: str | os.PathLike | None = None, *, force: bool = False) -> str:
        """The identified URDF (:meth:`IdentifiedModel.export_urdf`); written to ``path`` when given."""
        return self.model.export_urdf(path, force=force)

    def _plot(self, kind: str, ax):
        """The absolute torque error |e| of this method per joint and pooled: the mean and the [p5, p95]
        band [N·m, N] (:func:`pinid.report.plot_identification.error_bars`), against the torque as recorded.
        ``"validation"`` (the held-out recordings; the training data without them) or ``"train"``."""
        from pinid.report.plot_identification import error_bars  # loads matplotlib: on use only

        kind = "validation" if kind == "validation" and self.validation is not None else "training"
        metrics = self.validation if kind == "validation" else self.train
        title = f"{self.method}: absolute torque error ({kind}): mean (dot) and [p5, p95] band"
        return error_bars({self.method: metrics}, title=title)

    def text(self) -> str:
        """This method's detail as ``pinid identify --verbose`` prints it (consistency, the base parameters
        with σ, the torque errors)."""
        from pinid.identification.outputs import result_detail

        return result_detail(self).lstrip("\n")

    def to_dict(self, *, include_robot: bool = True) -> dict:
        """Plain-dict form (the entry of ``identification.json`` under ``methods``)."""
        d = {
            "method": self.method,
            "description": self.description,
            "settings": {
                k: (
                    v
                    if isinstance(v, (int, float, str, bool, type(None), dict, list, tuple))
                    else asdict(v)
                    if is_dataclass(v) and not isinstance(v, type)
                    else repr(v)
                )
                for k, v in self.settings.items()
            },
            "status": self.status,
            "base_parameters": self.base_parameters,
            "std": dict(zip(self.base_names, map(float, self.std))),
            "std_percent": dict(zip(self.base_names, map(float, self.std_percent))),
            "standard_parameters": self.standard_parameters,
            "standard_marks": self.marks,
            "standard_source": self.standard_source,
            "physically_consistent": bool(self.physically_consistent),
            "consistency": self.consistency,
            "condition_number": self.condition_number,
            "warning": self.warning,
            "residual_rms": self.residual_rms,
            "train": self.train.to_dict(),
            "validation": None if self.validation is None else self.validation.to_dict(),
            "train_filtered": None if self.train_filtered is None else self.train_filtered.to_dict(),
            "validation_filtered": None if self.validation_filtered is None else self.validation_filtered.to_dict(),
            "truth_error": self.truth_error,
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
        if not isinstance(d.get("physically_consistent"), bool):
            raise SpecError(
                f"result {d.get('method')!r}: 'physically_consistent' is {d.get('physically_consistent')!r}, "
                "expected true or false"
            )
        base_names = list(d["base_parameters"])
        std_names = list(d["standard_parameters"])
        num = lambda v: float("nan") if v is None else float(v)
        return cls(
            method=d["method"],
            base_names=base_names,
            base=np.array([num(d["base_parameters"][n]) for n in base_names]),
            std=np.array([num(d["std"][n]) for n in base_names]),
            standard_names=std_names,
            standard=np.array([num(d["standard_parameters"][n]) for n in std_names]),
            standard_source=d["standard_source"],
            physically_consistent=bool(d["physically_consistent"]),
            consistency=d.get("consistency") or {},
            condition_number=num(d["condition_number"]),
            train=TorqueMetrics.from_dict(d["train"]),
            seconds=float(d["seconds"]),
            validation=None if d.get("validation") is None else TorqueMetrics.from_dict(d["validation"]),
            settings=d.get("settings") or {},
            description=d.get("description", ""),
            status=d.get("status", "ok"),
            info=d.get("info") or {},
            history=d.get("history"),
            robot=robot if robot is not None else d.get("robot"),
            train_filtered=None if d.get("train_filtered") is None else TorqueMetrics.from_dict(d["train_filtered"]),
            validation_filtered=None
            if d.get("validation_filtered") is None
            else TorqueMetrics.from_dict(d["validation_filtered"]),
            truth_error=d.get("truth_error"),
            marks=_marks(d.get("standard_marks"), std_names, d.get("method")),
        )


@dataclass
class Identification(ResultProtocol):
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
    #: The model-class floor (:mod:`pinid.identification.floor`): the same terms fitted by least squares in-sample on
    #: the validation recordings, its torque error against the torque as recorded; None without validation.
    floor: TorqueMetrics | None = None

    PLOTS = {
        "errors": False,
        "parameters": False,
        "torque": False,
        "predictions": False,
        "motion": False,
        "choices": False,
    }
    PLOT_ARGUMENTS = ("torque",)
    FILE_KIND = "identification"

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
            v = m.headline()
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

    def _plot(self, kind: str, ax):
        """One figure of the report (:mod:`pinid.report.markdown`), the same drawing and title.

        ``"errors"`` (every method's absolute torque error per joint, validation when every method has it),
        ``"parameters"`` (the best method's and OLS's base parameters ±2σ against the URDF and the truth,
        divided by their natural scale), ``"torque"`` (the best method's measured and predicted torque
        [N·m] and its raw and filtered error; ``"torque:sdp"``: method sdp's), ``"predictions"`` (every
        method's predicted torque and its difference to the best's), ``"motion"`` (the recorded q, dq); the
        last three need the torque curves :func:`~pinid.identification.run.identify` keeps (not saved in the
        JSON); ``"choices"``: the cut-off and terms chosen by cross-validation (``--cutoff auto``,
        ``--terms auto``) and the held-out errors they were chosen on.
        """
        from pinid.report.markdown import figure_recipes  # loads the report (matplotlib on drawing): on use

        figure, _, method = kind.partition(":")
        if method and method not in self.results:
            raise SpecError(f"kind: no result for method '{method}' (methods run: {', '.join(self.results)})")
        key = f"torque_{method or self.best}" if figure == "torque" else figure
        recipes = figure_recipes(self)
        if key not in recipes:
            raise SpecError(
                f"kind: no '{figure}' figure "
                + (
                    "without a choice by cross-validation (--cutoff auto, --terms auto)"
                    if figure == "choices"
                    else "without the torque curves (a loaded result has none)"
                )
            )
        draw, args, kwargs = recipes[key]
        return draw(*args, **kwargs)

    def text(self) -> str:
        """What ``pinid identify`` prints: the data used and the summary table
        (:func:`pinid.identification.outputs.identification_text`)."""
        from pinid.identification.outputs import identification_text

        return identification_text(self)

    def to_dict(self) -> dict:
        """The content of ``identification.json``."""
        from pinid import __version__  # the package's own attribute: set after its submodules load

        return jsonable(
            {
                "pinid_version": __version__,
                "robot": self.robot,
                "data": self.data,
                "validation_sources": self.validation_sources,
                "base": self.base,
                "best": self.best if self.results else None,
                "seconds": self.seconds,
                "methods": {m: r.to_dict(include_robot=False) for m, r in self.results.items()},
                **({"floor": self.floor.to_dict()} if self.floor is not None else {}),
            }
        )

    @classmethod
    def from_dict(cls, d: dict) -> "Identification":
        """Rebuild from :meth:`to_dict`'s output (a loaded ``identification.json``); SpecError for a field
        missing or of the wrong type."""
        try:
            robot = d["robot"]
            results = {m: IdentificationResult.from_dict(r, robot=robot) for m, r in d["methods"].items()}
            return cls(
                robot,
                results,
                d.get("data") or {},
                d.get("base") or {},
                list(d.get("validation_sources") or []),
                float(d.get("seconds") or 0.0),
                floor=None if d.get("floor") is None else TorqueMetrics.from_dict(d["floor"]),
            )
        except PinidError:
            raise
        except (KeyError, TypeError, ValueError, AttributeError) as exc:  # a field missing or of the wrong type
            raise SpecError(
                f"not a valid identification ({type(exc).__name__}: {exc}); expected one written by pinid identify"
            ) from None

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Identification":
        """Read a file written by :meth:`save` (or ``pinid identify``)."""
        d = read_json(path, "identification")
        if "methods" not in d or "robot" not in d:
            raise SpecError(f"{path}: not an identification file (no 'methods' or 'robot')")
        if not isinstance(d["methods"], dict) or not d["methods"]:
            raise SpecError(f"{path}: 'methods' is {d['methods']!r}, expected an object of one result per method")
        try:
            return cls.from_dict(d)
        except SpecError as exc:
            raise SpecError(f"{path}: {exc}") from None


def make_result(
    problem: IdentificationProblem, estimator, seconds: float, *, complete: bool = True, robot: RobotModel | None = None
) -> IdentificationResult:
    """Check a fitted estimator and wrap it as an :class:`IdentificationResult` (training metrics included).
    ``robot``: the model the result belongs to when it is not ``problem.model`` (a floating base: the problem's
    model is its body view)."""
    if not hasattr(problem, "base"):
        raise SpecError(
            f"problem: got {type(problem).__name__}, expected an identification problem (IdentificationProblem)"
        )
    if robot is not None and not isinstance(robot, RobotModel):
        raise SpecError(f"robot: got {type(robot).__name__}, expected a RobotModel or None")
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
    # block by block: the tall regressor need not exist whole; one array of rows (the residual) unless the
    # torque as recorded differs from the fitted one (then the prediction is kept for its errors too)
    recorded = getattr(problem, "recorded_tau", None)
    predicted = problem.predict(base) if recorded is not None else None
    if predicted is None and hasattr(problem, "residual"):
        residual = problem.residual(base)
    else:
        residual = problem.tau - (problem.predict(base) if predicted is None else predicted)
    w = getattr(estimator, "weights_", None)  # wls: formed when read, let go before the metrics
    calibrated = getattr(estimator, "calibrated_std", True)
    # no calibrated σ (metaheuristics): the white formula for the condition numbers, no HAC lag to refuse
    kind = {} if calibrated else {"kind": "white"}  # (bench_coverage.py swaps base_statistics' default kind)
    std, cond, cond_scaled = base_statistics(problem, base, w, residual=residual, **kind)
    del w
    raw_std = std  # the information in the data, for the marks (data_marks), before any σ is withheld
    if not calibrated:
        std = np.full_like(std, np.nan)  # no calibrated σ: none printed rather than a wrong one
    elif getattr(estimator, "consistent_by_construction", False):
        std = np.where(np.abs(base) <= BOUND_FRACTION * problem.natural_scale, np.nan, std)  # on a bound
    info["condition_number_scaled"] = cond_scaled
    joints, units = problem.model.joint_names, joint_units(problem.model)
    shift = getattr(problem, "offset_shift", None)  # offsets per recording: their means back in (yardsticks)
    tau = problem.tau if shift is None else problem.tau + shift
    filtered = error_metrics(tau, residual, joints, problem.joint, units)  # overwrites the residual
    del residual
    if recorded is not None and shift is not None:
        recorded, predicted = recorded + shift, predicted + shift
    train = filtered if recorded is None else torque_metrics(recorded, predicted, joints, problem.joint, units)
    return IdentificationResult(
        method=estimator.name,
        base_names=problem.names,
        base=base,
        std=std,
        standard_names=std_names,
        standard=theta,
        standard_source=source,
        physically_consistent=bool(consistent),
        consistency=report.to_dict(),
        condition_number=cond,
        train=train,
        train_filtered=filtered,
        seconds=float(seconds),
        settings=estimator.get_params(),
        description=estimator.description,
        status=str(getattr(estimator, "status_", "ok")),
        info=info,
        history=getattr(estimator, "history_", None),
        robot=robot_to_dict(robot or problem.model, problem.terms),
        marks=data_marks(problem, raw_std, theta if getattr(estimator, "consistent_by_construction", False) else None),
        _robot_model=robot or problem.model,
    )


#: A base parameter whose σ exceeds this share of its natural magnitude (:attr:`IdentificationProblem.natural_scale`:
#: M, M·L, M·L² per body, 1 in its unit for a joint term) is not determined by the data (:func:`data_marks`).
UNDETERMINED_SIGMA = 0.5


def _identification_problem(problem) -> None:
    """SpecError unless ``problem`` is an identification problem (its base map, joints and model)."""
    if not all(hasattr(problem, a) for a in ("base", "nv", "nb", "model", "terms", "natural_scale")):
        raise SpecError(f"problem: got {type(problem).__name__}, expected an identification problem")


def still_joints(problem) -> list[int]:
    """The joints (indices) that stand still in ``problem``'s recordings: peak speed below
    :data:`~pinid.problem.rows.REST_FRACTION` (2 %) of the fastest joint's of the same unit (rad/s or m/s) — the
    rest rule of :mod:`pinid.problem.problem` taken over the robot instead of the joint.  [] without the
    recordings (a segmental stage's sub-problem)."""
    from pinid.problem.rows import REST_FRACTION

    _identification_problem(problem)
    rows = getattr(problem, "regressor_rows", None)
    if rows is None or not rows.datasets:
        return []
    try:
        peak = np.max([np.max(np.abs(ds.dq), axis=0) for ds in rows.datasets if ds.n], axis=0)
        units = joint_units(problem.model)
    except (AttributeError, TypeError, ValueError):  # recordings without joint velocities of this model's shape
        return []
    if len(peak) != len(units):
        return []
    out = []
    for j, u in enumerate(units):
        same = [k for k, v in enumerate(units) if v == u]
        if peak[j] < REST_FRACTION * max(peak[k] for k in same):
            out.append(j)
    return out


def data_marks(problem, std: np.ndarray, theta: np.ndarray | None = None) -> dict[str, str]:
    """``{standard name: mark}`` from the information in these data (issue 47), not from the model's structure
    alone.  Three steps:

    1. A joint that stands still (:func:`still_joints`) gives no information on its motion terms (friction,
       armature …; not its offset): their columns are dropped from ``P``.
    2. A base parameter whose σ (``std``, the method's own sandwich) exceeds :data:`UNDETERMINED_SIGMA` of its
       natural magnitude is not determined by the data (its ±2σ interval spans its whole size): its row of
       ``P`` is dropped.  NaN σ (none given) drops nothing.
    3. :func:`~pinid.model.base.identifiability` of what is left: ``"identified"``, ``"partly"``, ``"not
       identified"``.  With ``theta`` (an estimator that holds bounds, sdp): a non-negative joint term that is
       not "not identified" and sits on its bound 0 (≤ :data:`BOUND_FRACTION` in its unit) is ``"at bound"``.
    """
    from pinid.model.base import identifiability
    from pinid.model.terms import robot_layout

    _identification_problem(problem)
    if isinstance(std, (str, bytes)) or np.ndim(std) != 1 or len(std) != problem.nb:
        raise SpecError(f"std: got {type(std).__name__}, expected one standard deviation per base parameter")
    base = problem.base
    P = np.array(base.P, dtype=float)
    names = base.standard_names
    layout = robot_layout(problem.model, problem.terms)
    first = len(names) - len(layout)
    still = set(still_joints(problem))
    for k, prm in enumerate(layout):
        if prm.term.space == "joint" and prm.index in still and prm.term.name != "offset" and not prm.term.static:
            P[:, first + k] = 0.0
    std = np.asarray(std, dtype=float)
    scale = problem.natural_scale
    undetermined = np.isfinite(std) & (std > UNDETERMINED_SIGMA * scale)
    P[undetermined] = 0.0
    marks = dict(zip(names, identifiability(P)))
    if theta is not None:
        for k, prm in enumerate(layout):
            n = names[first + k]
            if prm.term.nonnegative and marks[n] != MARKS[2] and abs(theta[first + k]) <= BOUND_FRACTION:
                marks[n] = MARKS[3]
    return marks


def _marks(value, names: list[str], method) -> dict[str, str] | None:
    """The ``standard_marks`` of a saved result, checked (None when absent: a file of an older pinid)."""
    if value is None:
        return None
    if not isinstance(value, dict) or set(value) != set(names) or not set(value.values()) <= set(MARKS):
        raise SpecError(
            f"result {method!r}: 'standard_marks' must map each standard parameter to one of {', '.join(MARKS)}"
        )
    return {n: value[n] for n in names}


def load_identified(path: str | os.PathLike, *, method: str | None = None) -> IdentifiedModel:
    """The identified model of ``path``: an identification (``identification.json``: its best method, or
    ``method``) or an identified model (``model_<method>.json``).  SpecError naming the file otherwise."""
    d = read_json(path, "pinid identification or identified model")
    if isinstance(d, dict) and "methods" in d and "robot" in d:
        ident = Identification.from_dict(d)
        if method is not None and method not in ident.results:
            raise SpecError(f"{path}: no method '{method}' (methods: {', '.join(ident.results)})")
        return ident.results[method or ident.best].model
    meta = d.get("meta") if isinstance(d, dict) else None
    if method is not None and isinstance(meta, dict) and meta.get("method") not in (None, method):
        raise SpecError(f"{path}: holds method '{meta['method']}', not '{method}'")
    try:
        return IdentifiedModel.from_dict(d)
    except SpecError as exc:
        raise SpecError(f"{path}: {exc}") from None
