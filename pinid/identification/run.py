"""One way through: recordings → problem → methods × seeds → results, behind :func:`identify` and
:func:`pinid.identification.compare.compare`.

* :func:`parse_methods`, :func:`check_options` (and :func:`pinid.model.terms.as_terms`) — the one place
  where method names, joint terms and per-method settings are read (the CLI passes its strings straight through);
* :func:`setup` — the model, the training problem (or the segmental stages) and the validation sets;
* :func:`run_jobs` — fits one estimator per ``(method, seed, settings)`` job on the setup, times each
  fit and wraps it as an :class:`~pinid.identification.result.IdentificationResult`.

:func:`identify` runs each method once and validates; ``compare`` runs the metaheuristics once per seed
and measures more (:mod:`pinid.identification.compare`).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from pinid.data.dataset import Dataset
from pinid.errors import DataError, SpecError
from pinid.estimators import ESTIMATORS, Estimator, make_estimator
from pinid.identification.metrics import joint_units, torque_metrics
from pinid.identification.problem import (
    REST_FRACTION,
    IdentificationProblem,
    check_dataset,
    load_datasets,
    predict_torque,
    recorded_torque,
)
from pinid.identification.result import Identification, IdentificationResult, make_result
from pinid.identification.segmental import Segmental, SegmentalProblem
from pinid.identification.stribeck import fit_velocity, with_stribeck
from pinid.identification.truth import read_truth, true_base, truth_error
from pinid.model.base import BaseParameters, base_parameters
from pinid.model.regressor import JointTerms
from pinid.model.robot import RobotModel
from pinid.model.terms import STRIBECK_TERMS, Stribeck, as_terms, stribeck, stribeck_settings
from pinid.model.serialize import robot_to_dict
from pinid.progress import progress

#: Default methods of :func:`identify` and ``pinid identify``.
DEFAULT_METHODS: tuple[str, ...] = ("ols", "wls", "sdp")


# ====================================================================== parsing (one place)
def parse_methods(methods: Sequence[str] | str | None, default: Sequence[str] = DEFAULT_METHODS) -> list[str]:
    """Method names from ``"ols,sdp"``, a list, ``"all"`` or None (``default``); lower case, no repeats.

    SpecError for an empty list or a name not in :data:`pinid.estimators.ESTIMATORS`.
    """
    if methods is None:
        methods = list(default)
    elif not isinstance(methods, (str, list, tuple)):
        raise SpecError(f'methods {methods!r}: expected "ols,sdp", a list of names or "all"')
    elif isinstance(methods, str):
        if methods.strip().lower() == "all":
            methods = list(ESTIMATORS)
        else:
            methods = [m.strip() for m in methods.split(",") if m.strip()]
    names = list(dict.fromkeys(str(m).strip().lower() for m in methods))
    if not names:
        raise SpecError(f"no method given, expected some of {', '.join(ESTIMATORS)}")
    unknown = [m for m in names if m not in ESTIMATORS]
    if unknown:
        listed = ", ".join(f"'{m}'" for m in unknown)
        raise SpecError(
            f"unknown method{'s' if len(unknown) > 1 else ''} {listed}, expected one of {', '.join(ESTIMATORS)}"
        )
    return names


def check_options(options: Mapping[str, Mapping] | None, methods: Sequence[str]) -> dict[str, dict]:
    """Per-method settings with lower-case keys; SpecError for settings of a method that is not run."""
    if options is not None and (
        not isinstance(options, Mapping) or not all(isinstance(v, Mapping) for v in options.values())
    ):
        raise SpecError(f"options {options!r}: expected {{method: {{setting: value}}}}")
    options = {str(k).strip().lower(): dict(v) for k, v in dict(options or {}).items()}
    bad = [k for k in options if k not in methods]
    if bad:
        raise SpecError(f"options for method(s) {', '.join(bad)} that are not run (methods: {', '.join(methods)})")
    return options


def as_model(model: RobotModel | str | os.PathLike) -> RobotModel:
    """A RobotModel as it is, or loaded from a URDF path or a bundled robot's name."""
    return model if isinstance(model, RobotModel) else RobotModel.from_urdf(model)


# ====================================================================== the setup and the runner
@dataclass
class Setup:
    """Everything the runs share: the model, the training problem (or segmental stages), validation sets."""

    model: RobotModel
    terms: JointTerms
    base: BaseParameters
    problem: IdentificationProblem
    train: list[Dataset]
    validation: dict[str, list[Dataset]] = field(default_factory=dict)
    segmental: SegmentalProblem | None = None
    stribeck: dict[str, dict] = field(default_factory=dict)  # the Stribeck shapes used (data["stribeck"])


def setup(
    model: RobotModel,
    data,
    validate=None,
    *,
    terms: JointTerms = JointTerms(),
    mapping=None,
    preprocess: Mapping | bool | None = None,
    rest_velocity="auto",
    rest_fraction: float = REST_FRACTION,
    segmental: Mapping | None = None,
    show_progress: bool | None = False,
    stribeck_auto: Mapping[str, bool] | None = None,
) -> Setup:
    """Load and stack the recordings.  ``validate``: recordings, or ``{label: recordings}``;
    ``segmental``: ``{"first": recordings, "joints": first joints}`` (seed 000's two stages);
    ``stribeck_auto``: ``{Stribeck term: fit its shape too}`` — their velocities are fitted
    (:mod:`pinid.identification.stribeck`) and set in ``model.stribeck`` (a model of the caller's own:
    :func:`~pinid.identification.stribeck.with_stribeck`)."""
    auto = dict(stribeck_auto or {})
    if auto and segmental:
        raise SpecError("Stribeck velocity 'auto' with the segmental strategy: give the velocity instead")
    final_terms, terms = terms, JointTerms(names=[n for n in terms.names if n not in auto])
    check_distinct(data, validate)
    train = load_datasets(data, model, mapping, preprocess, "training")
    if validate is None:
        val = {}
    elif isinstance(validate, Mapping):
        val = {str(k): load_datasets(v, model, mapping, preprocess, f"validation ({k})") for k, v in validate.items()}
    else:
        val = {"validation": load_datasets(validate, model, mapping, preprocess, "validation")}
    base = base_parameters(model, terms)
    seg = None
    if segmental:
        unknown_keys = [k for k in segmental if k not in ("first", "joints")]
        if unknown_keys or "first" not in segmental:
            raise SpecError(
                "segmental: expected {'first': recordings with only the first joints moving, "
                "'joints': (first joints, default knee)}"
            )
        first = load_datasets(segmental["first"], model, mapping, preprocess, "first-stage")
        seg = SegmentalProblem(
            model,
            first,
            train,
            first_joints=tuple(segmental.get("joints", ("knee",))),
            terms=terms,
            rest_velocity=rest_velocity,
            rest_fraction=rest_fraction,
            base=base,
        )
        problem = seg.problem
    else:
        problem = IdentificationProblem.from_datasets(
            model,
            train,
            terms=terms,
            base=base,
            rest_velocity=rest_velocity,
            rest_fraction=rest_fraction,
            show_progress=show_progress,
        )
    shapes = {
        n: {"velocity": v.velocity, "shape": v.shape, "fitted": False}
        for n in final_terms.names
        if n in STRIBECK_TERMS
        for v in [stribeck(model, n)]
    }
    for k, name in enumerate(auto):  # one 1-D search per term, around the linear fit without it
        fit = fit_velocity(problem, train, name, fit_shape=auto[name])
        model.stribeck[name] = Stribeck(fit.velocity, fit.shape)
        shapes[name] = fit.summary()
        terms = JointTerms(names=[n for n in final_terms.names if n not in list(auto)[k + 1 :]])
        base = base_parameters(model, terms)
        problem = IdentificationProblem.from_datasets(
            model, train, terms=terms, base=base, rest_velocity=rest_velocity, rest_fraction=rest_fraction
        )
    return Setup(model, terms, base, problem, train, val, seg, shapes)


def _items(recordings) -> list:
    """The recordings given as one or several (Datasets, paths)."""
    if recordings is None:
        return []
    if isinstance(recordings, (Dataset, str, os.PathLike)):
        return [recordings]
    return list(recordings) if isinstance(recordings, Iterable) else [recordings]


def _key(item):
    """What makes two recordings the same one: the resolved path, or the Dataset object."""
    return os.path.realpath(item) if isinstance(item, (str, os.PathLike)) else id(item)


def check_distinct(data, validate=None) -> None:
    """DataError for a training recording given twice (its rows would count twice: the standard deviations
    shrink by √2 with no new information); a DataWarning for a validation recording that is also a
    training one (then the validation error is a training error)."""
    from pinid.data.formats import warn

    seen: dict = {}
    for item in _items(data):
        k = _key(item)
        if k in seen:
            raise DataError(f"{item}: given twice as training data (also {seen[k]}); expected each recording once")
        seen[k] = item
    groups = validate.values() if isinstance(validate, Mapping) else [validate]
    for item in (i for g in groups for i in _items(g)):
        if _key(item) in seen:
            warn(
                None,
                f"{item}: the validation recording is also a training recording, so its error is a "
                "training error, not a validation; expected a different trajectory",
            )


@dataclass
class Fit:
    """One job's outcome: the fitted estimator, its wrapped result and the fit time [s]."""

    method: str
    seed: int | None
    settings: dict
    estimator: Estimator
    result: IdentificationResult
    seconds: float


def run_jobs(
    s: Setup,
    jobs: Iterable[tuple[str, int | None, dict]],
    *,
    complete: bool = True,
    show_progress: bool | None = False,
    label: str = "methods",
) -> list[Fit]:
    """Fit every ``(method, seed, settings)`` job on the setup's problem (or its segmental stages)."""
    jobs = list(jobs)
    fits = []
    bar = progress(len(jobs), label, enabled=show_progress)
    try:
        for method, seed, settings in jobs:
            bar.set_description(method + ("" if seed is None else f" seed {seed}"))
            if s.segmental is not None:
                est, target = Segmental(method, settings), s.segmental
            else:
                est, target = make_estimator(method, **settings), s.problem
                s.problem.__dict__.pop("_compressed", None)  # each run's time includes its QR compression
            t0 = time.perf_counter()
            est.fit(target)
            seconds = time.perf_counter() - t0
            fits.append(
                Fit(method, seed, settings, est, make_result(s.problem, est, seconds, complete=complete), seconds)
            )
            bar.update(1)
    finally:
        bar.close()
    return fits


# ====================================================================== identify
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
    payload=None,
    payload_data: Dataset | str | os.PathLike | Iterable | None = None,
    stribeck_velocity: float | str | Mapping | None = None,
    stribeck_shape: float | str | Mapping | None = None,
    truth=None,
) -> Identification:
    """Identify ``model``'s dynamic parameters from recordings with several methods; validate; compare.

    ``model``: a RobotModel, URDF path or robot name.  ``data`` / ``validate``: Datasets or recording
    paths (read with :func:`pinid.data.formats.read_recording` and ``mapping``).  Recordings without ``dq`` or
    ``ddq`` go through :func:`pinid.data.preprocess.prepare` (see
    :func:`~pinid.identification.problem.prepare_dataset` for ``preprocess``).
    ``methods``: names from :data:`pinid.estimators.ESTIMATORS` (default ols, wls, sdp).  ``terms``: the
    joint terms in the model (default Coulomb and viscous friction).  ``rest_velocity``,
    ``rest_fraction``: rows at rest dropped for Coulomb friction (:mod:`pinid.identification.problem`).
    ``options``: settings per method, e.g. ``{"sdp": {"regularization": 1e-2, "mass_bounds": (0.1, 20)}}``.
    ``complete``: look for a consistent standard set behind base-only results (one small SDP each).
    ``payload`` (a :class:`~pinid.identification.gains.Payload` or its TOML) with ``payload_data``: the
    recordings hold currents, not torques; the drive gains are identified from them and the payload
    recordings first (:mod:`pinid.identification.gains`), the currents turned into torques, and the
    gains reported in ``data["drive_gains"]``.
    ``stribeck_velocity`` [rad/s], ``stribeck_shape``: the shape of the Stribeck terms (``fs``,
    ``motor_fs``; :func:`pinid.model.terms.stribeck_settings`), default the model's (``model.stribeck``)
    or 0.1 rad/s and 2; ``"auto"`` fits the velocity (and the shape: :mod:`pinid.identification.stribeck`).  The shapes
    used are in ``data["stribeck"]`` and in the saved robot.
    ``truth``: the truth of a twin (``pinid simulate``'s ``run.truth.json``, its path or dict): every
    result gets ``truth_error``, its error against the true base parameters (:mod:`pinid.identification.truth`).
    Torque errors are against the torque as recorded (``result.validation``, ``result.train``) and after
    the preprocessing's low-pass (``validation_filtered``, ``train_filtered``).

    Returns an :class:`~pinid.identification.result.Identification`; ``result.model`` is the best
    result's :class:`~pinid.identification.identified.IdentifiedModel`, ``result["sdp"]`` one method's result.
    """
    t_start = time.perf_counter()
    model = as_model(model)
    terms = as_terms(terms)
    methods = parse_methods(methods)
    options = check_options(options, methods)
    for m in methods:  # bad settings fail before any recording is read
        make_estimator(m, **options.get(m, {}))
    if truth is not None:
        read_truth(truth)  # an unreadable truth fails before any recording is read
    settings, auto = stribeck_settings(model, terms, stribeck_velocity, stribeck_shape)
    if auto and payload is not None:
        raise SpecError("Stribeck velocity 'auto' with drive gains (--payload): give the velocity instead")
    model = with_stribeck(model, settings) if settings else model
    gains = None
    if payload is not None or payload_data is not None:
        gains, data, validate = _currents_to_torques(
            model, terms, data, validate, payload, payload_data, mapping, preprocess, rest_velocity
        )
        preprocess = False
    s = setup(
        model,
        data,
        validate,
        terms=terms,
        mapping=mapping,
        preprocess=preprocess,
        rest_velocity=rest_velocity,
        rest_fraction=rest_fraction,
        show_progress=show_progress,
        stribeck_auto=auto,
    )
    x_true = None if truth is None else true_base(truth, s.model, s.terms, s.base)  # checked before the fits
    fits = run_jobs(s, [(m, None, options.get(m, {})) for m in methods], complete=complete, show_progress=show_progress)
    results = {f.method: f.result for f in fits}
    if x_true is not None:
        for r in results.values():
            r.truth_error = truth_error(r.base, x_true, s.problem.natural_scale, s.base.names)
    values = {m: r.base for m, r in results.items()}
    val_sets = s.validation.get("validation", [])
    if val_sets:
        checked = [check_dataset(ds, model) for ds in val_sets]
        preds = [predict_torque(model, terms, s.base, ds, values) for ds in checked]
        tau_all = np.concatenate([ds.tau for ds in checked])
        recorded = np.concatenate([recorded_torque(ds) for ds in checked])
        units = joint_units(model)
        for m, r in results.items():
            pred = np.concatenate([p[m] for p in preds])
            r.validation = torque_metrics(recorded, pred, model.joint_names, units=units)
            r.validation_filtered = torque_metrics(tau_all, pred, model.joint_names, units=units)
        first = checked[0]
        curves = {
            "kind": "validation",
            "source": first.source,
            "t": first.t,
            "measured": recorded_torque(first),
            "filtered": first.tau,
            "units": units,
            "predicted": preds[0],
        }
    else:
        ds = check_dataset(s.train[0], model)
        curves = {
            "kind": "training",
            "source": ds.source,
            "t": ds.t,
            "measured": recorded_torque(ds),
            "filtered": ds.tau,
            "units": joint_units(model),
            "predicted": predict_torque(model, terms, s.base, ds, values),
        }
    if s.train:  # the training motion, drawn as the report's "excitation" figure
        ds = s.train[0]
        curves["motion"] = {"source": ds.source, "t": ds.t, "q": ds.q, "dq": ds.dq}
    summary = s.problem.summary()
    if gains is not None:
        summary["drive_gains"] = gains.summary()
    if s.stribeck:
        summary["stribeck"] = s.stribeck
    return Identification(
        robot=robot_to_dict(model, terms),
        results=results,
        data=summary,
        base={
            "names": s.base.names,
            "expressions": s.base.expressions(),
            "nominal": s.base.from_standard(s.problem.nominal).tolist(),
        },
        validation_sources=[ds.source for ds in val_sets],
        seconds=time.perf_counter() - t_start,
        curves=curves,
    )


def _currents_to_torques(model, terms, data, validate, payload, payload_data, mapping, preprocess, rest_velocity):
    """``(gains, training, validation)``: drive gains from the recordings with and without the payload, and
    the recordings' currents turned into torques (see :mod:`pinid.identification.gains`)."""
    from pinid.identification.gains import Payload, identify_gains

    if payload is None or payload_data is None:
        raise SpecError(
            "drive gains need both the payload (--payload FILE) and a recording with it (--payload-data FILE)"
        )
    payload = payload if isinstance(payload, Payload) else Payload.load(payload)
    train = load_datasets(data, model, mapping, preprocess, "training")
    loaded = load_datasets(payload_data, model, mapping, preprocess, "payload")
    gains = identify_gains(model, train, loaded, payload, terms=terms, rest_velocity=rest_velocity)

    def torques(items, what):
        return [gains.apply(ds) for ds in load_datasets(items, model, mapping, preprocess, what)]

    if isinstance(validate, Mapping):
        validate = {k: torques(v, f"validation ({k})") for k, v in validate.items()}
    elif validate is not None:
        validate = torques(validate, "validation")
    return gains, [gains.apply(ds) for ds in train], validate
