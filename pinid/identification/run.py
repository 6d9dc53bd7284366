"""One way through: recordings → problem → methods × seeds → results, behind :func:`identify` and
:func:`pinid.identification.compare.compare`.

* :func:`parse_methods`, :func:`check_options` (and :func:`pinid.model.terms.as_terms`) — the one place
  where method names, joint terms and per-method settings are read (the CLI passes its strings straight through);
* :func:`setup` — the model, the training problem (or the segmental stages) and the validation sets
  (a :class:`~pinid.identification.runner.Setup`), fitted by :func:`pinid.identification.runner.run_jobs`.

:func:`identify` runs each method once and validates; ``compare`` runs the metaheuristics once per seed
and measures more (:mod:`pinid.identification.compare`).
"""

from __future__ import annotations

import os
import time
import warnings
from dataclasses import replace
from collections.abc import Callable, Mapping, Sequence

import numpy as np

from pinid.data.delay import parse_delay, shift_torque
from pinid.errors import DataError, SpecError
from pinid.estimators import ESTIMATORS, make_estimator
from pinid.identification.mass import fixed_total_mass
from pinid.identification.metrics import joint_units, torque_metrics
from pinid.identification.recording_checks import (
    check_payload_data_distinct,
    recording_items,
    check_distinct,
    warn_if_large_recordings,
)
from pinid.identification.offsets import check_offset_options, offset_validation, offsets_summary, profile_offsets
from pinid.problem.problem import (
    IdentificationProblem,
    check_dataset,
    predict_torque,
    recorded_torque,
)
from pinid.problem.recordings import load_datasets
from pinid.problem.rows import fit_mask
from pinid.identification.result import Identification
from pinid.identification.runner import Setup, run_jobs
from pinid.parallel import check_workers
from pinid.identification.segmental import SegmentalProblem
from pinid.identification.study import Study
from pinid.identification.stribeck import fit_velocity
from pinid.identification.term_choice import is_default, parse_auto
from pinid.identification.truth import read_truth, true_base, truth_error
from pinid.model.base import base_parameters
from pinid.model.terms import TermSelection
from pinid.model.terms import STRIBECK_TERMS, Stribeck, as_terms, stribeck, stribeck_settings
from pinid.model.serialize import robot_to_dict
from pinid.model.robot import as_robot

#: Default methods of :func:`identify` and ``pinid identify``.
DEFAULT_METHODS: tuple[str, ...] = ("ols", "wls", "sdp")
#: What :func:`identify`, ``compare`` and :func:`setup` say of a first argument that is not a Study.
EXPECTED_STUDY = "expected a Study (pinid.Study(model, data, …))"
#: Other names of registry methods that :func:`parse_methods` accepts (the docs call sdp "the LMI method").
METHOD_ALIASES: dict[str, str] = {"lmi": "sdp"}


# ====================================================================== parsing (one place)
def parse_methods(methods: Sequence[str] | str | None, default: Sequence[str] = DEFAULT_METHODS) -> list[str]:
    """Method names from ``"ols,sdp"``, a list, ``"all"`` or None (``default``); lower case, no repeats;
    an alias of :data:`METHOD_ALIASES` (``lmi``) becomes its method (``sdp``).

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
    names = [str(m).strip().lower() for m in methods]
    names = list(dict.fromkeys(METHOD_ALIASES.get(m, m) for m in names))
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


# ====================================================================== the setup and the runner
def setup(
    study: Study, *, show_progress: bool | None = False, stribeck_auto: Mapping[str, bool] | None = None
) -> Setup:
    """Load and stack the recordings of ``study`` (a :class:`~pinid.identification.study.Study`): its model,
    training problem (or ``study.segmental``'s two stages: ``{"first": recordings, "joints": first joints}``,
    seed 000's) and validation sets.  ``stribeck_auto``: ``{Stribeck term: fit its shape too}`` — their
    velocities are fitted (:mod:`pinid.identification.stribeck`); ``Setup.model`` is then a new model with the
    fitted shapes (``model.with_stribeck``), the study's is left as it is.  ``study.fit_joints``: the joints
    whose torque rows enter the fit (default all); ``study.delay``: the torque channels' delay behind the
    positions (:func:`pinid.data.delay.parse_delay`; ``"auto"`` estimated on the training recordings,
    ``"auto-per-joint"`` one per channel, :mod:`pinid.identification.delay`), applied to every recording.
    ``show_progress``: a progress bar while the rows are stacked.  A floating-base ``study.model``: its recordings
    with base motion and contact wrenches, stacked in its 6 + n rows per sample (``study.floating``), the
    validation rows and the raw recordings' convention hints in ``Setup.floating``."""
    if not isinstance(study, Study):
        raise SpecError(f"study: got {type(study).__name__}, {EXPECTED_STUDY}")
    if getattr(study.model, "base", "fixed") == "floating":
        if stribeck_auto:
            raise SpecError("Stribeck velocity 'auto': not available with a floating base; give the velocity")
        return _setup_floating(study)
    model, data, validate, terms, mapping = study.model, study.data, study.validate, study.terms, study.mapping
    preprocess, rest_velocity, rest_fraction = study.preprocess, study.rest_velocity, study.rest_fraction
    segmental, fit_joints, delay = study.segmental, study.fit_joints, study.delay
    keep = parse_auto(terms)  # terms "auto[,added…]": chosen by forward selection, starting from the added ones
    auto_terms, default_terms = keep is not None, is_default(terms)
    model, terms = as_robot(model), TermSelection() if auto_terms else as_terms(terms)  # resolved ones as they are
    auto = dict(stribeck_auto or {})
    # the default's offset test: not beside another choice of the terms' shapes, the segmental stages or offsets
    # per recording (an offset term is collinear with those)
    default_terms = default_terms and not (auto or segmental or study.offsets is not None)
    if auto_terms and (auto or segmental):
        raise SpecError("terms auto with Stribeck velocity 'auto' or the segmental strategy: give the terms instead")
    fit = fit_mask(model, fit_joints)  # a bad joint name fails before any recording is read
    fitted = None if fit.all() else [j for j, f in zip(model.joint_names, fit) if f]  # None: every joint
    rows = {"rest_velocity": rest_velocity, "rest_fraction": rest_fraction, "fit_joints": fit_joints}
    delays = parse_delay(delay, model.joint_names)
    if segmental and (fit_joints is not None or delays is not None):
        raise SpecError("fit joints and torque delays with the segmental strategy: not supported")
    if auto and segmental:
        raise SpecError("Stribeck velocity 'auto' with the segmental strategy: give the velocity instead")
    if auto_terms and study.offsets is not None:
        raise SpecError("terms auto with offsets per recording: give the terms instead")
    validated = validate is not None and any(
        recording_items(v) for v in (validate.values() if isinstance(validate, Mapping) else [validate])
    )
    offsets = check_offset_options(study.offsets, study.calibrate_offsets, terms, len(recording_items(data)), validated)
    final_terms, terms = terms, TermSelection(names=[n for n in terms.names if n not in auto])
    check_distinct(data, validate)
    ripple_auto = _is_auto(model.setting("ripple_periods"))  # chosen below; the cut-off's choice goes without
    cv_terms = TermSelection(names=[n for n in terms.names if not n.startswith("ripple_")]) if ripple_auto else terms
    chosen = None
    if isinstance(preprocess, Mapping) and isinstance(preprocess.get("cutoff"), str):
        if not _is_auto(preprocess["cutoff"]):
            raise SpecError(f"cut-off {preprocess['cutoff']!r}, expected a frequency > 0 [Hz] or auto")
        from pinid.identification.cutoff import choose_cutoff  # loaded on use

        base = base_parameters(model, cv_terms, joints=fitted)
        chosen = choose_cutoff(
            model,
            recording_items(data),
            terms=cv_terms,
            base=base,
            mapping=mapping,
            preprocess=preprocess,
            problem_options=rows,
        )
        preprocess = {**preprocess, "cutoff": chosen.cutoff}
    glitches = _glitch_check(model)  # an encoder glitch in a raw recording: named (issue 47)
    train = load_datasets(data, model, mapping, preprocess, "training", check=glitches)
    terms_choice = None
    if auto_terms:
        from pinid.identification.term_choice import choose_terms  # loaded on use

        terms_choice = choose_terms(model, train, fit_joints=fitted, problem_options=rows, keep=keep)
        terms = final_terms = TermSelection(names=terms_choice.terms)
    elif default_terms:
        from pinid.identification.term_choice import choose_default_terms  # loaded on use

        terms_choice = choose_default_terms(model, train, fit_joints=fitted, problem_options=rows)
        terms = final_terms = TermSelection(names=terms_choice.terms)
    ripple = None
    if ripple_auto:
        from pinid.identification.ripple_choice import choose_ripple_periods  # loaded on use

        ripple = choose_ripple_periods(model, train, terms, fit_joints=fitted, problem_options=rows)
        model = model.with_setting("ripple_periods", ripple.periods)
        if not ripple.helps:  # a choice is adopted only when it wins on the held-out blocks (issue 44)
            terms = TermSelection(names=[n for n in terms.names if not n.startswith("ripple_")])
            final_terms = TermSelection(names=[n for n in final_terms.names if not n.startswith("ripple_")])
    sigmoid = None
    if _is_auto(model.setting("sigmoid")):  # the sigmoid friction's shape (identification.sigmoid)
        from pinid.identification.sigmoid import fit_sigmoid  # loaded on use (scipy.optimize)

        model, sigmoid = fit_sigmoid(model, train, terms, fit_joints=fitted, problem_options=rows)
    warn_if_large_recordings(model, terms, train)
    if validate is None:
        val = {}
    elif isinstance(validate, Mapping):
        val = {
            str(k): load_datasets(v, model, mapping, preprocess, f"validation ({k})", check=glitches)
            for k, v in validate.items()
        }
    else:
        val = {"validation": load_datasets(validate, model, mapping, preprocess, "validation", check=glitches)}
    base = base_parameters(model, terms, joints=fitted)
    used_delay = None
    if delays is not None:
        if isinstance(delays, str):
            from pinid.identification.delay import estimate_delay  # loaded on use (scipy.optimize)

            used_delay = estimate_delay(
                model,
                train,
                terms=terms,
                base=base,
                rest_velocity=rest_velocity,
                rest_fraction=rest_fraction,
                fit_joints=fit_joints,
                per_joint=delays == "auto-per-joint",
            )
            delays = np.asarray(used_delay.pop("per_joint_delays", np.full(model.nv, used_delay["delay"])))
        used_delay = {
            **(used_delay or {}),
            "estimated": used_delay is not None,
            "per_joint": {j: float(v) for j, v in zip(model.joint_names, delays)},
        }
        train = [shift_torque(check_dataset(ds, model), delays) for ds in train]
        val = {k: [shift_torque(check_dataset(ds, model), delays) for ds in v] for k, v in val.items()}
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
            fit_joints=fit_joints,
        )
    shapes = {
        n: {"velocity": v.velocity, "shape": v.shape, "fitted": False}
        for n in final_terms.names
        if n in STRIBECK_TERMS
        for v in [stribeck(model, n)]
    }
    # One 1-D search per term, around the linear fit without it; then the problem is built again with the
    # term.  It cannot be built once: the term's columns depend on the fitted velocity, and with them the
    # base parameters (the structural QR on random samples) and every stacked row; appending columns to the
    # problem of the search would give other base parameters and other digits.
    for k, name in enumerate(auto):
        fit = fit_velocity(problem, train, name, fit_shape=auto[name])
        model = model.with_stribeck({name: Stribeck(fit.velocity, fit.shape)})
        shapes[name] = fit.summary()
        terms = TermSelection(names=[n for n in final_terms.names if n not in list(auto)[k + 1 :]])
        base = base_parameters(model, terms, joints=base.fit_joints)
        problem = IdentificationProblem.from_datasets(
            model,
            train,
            terms=terms,
            base=base,
            rest_velocity=rest_velocity,
            rest_fraction=rest_fraction,
            fit_joints=fit_joints,
        )
    return Setup(
        model,
        terms,
        base,
        problem,
        train,
        val,
        seg,
        shapes,
        used_delay,
        chosen and chosen.to_dict(),
        terms_choice and terms_choice.to_dict(),
        ripple and ripple.to_dict(),
        sigmoid,
        None if offsets is None else profile_offsets(problem, study.calibrate_offsets),
    )


def _is_auto(value) -> bool:
    """True for the text ``"auto"`` (any case, spaces around): a setting the training recordings choose."""
    return isinstance(value, str) and value.strip().lower() == "auto"


def identify(
    study: Study,
    methods: Sequence[str] | str = DEFAULT_METHODS,
    *,
    options: Mapping[str, Mapping] | None = None,
    complete: bool = True,
    show_progress: bool | None = False,
    started: Callable[[], None] | None = None,
    truth=None,
    workers: int | None = 1,
) -> Identification:
    """Identify the dynamic parameters of ``study``'s model from its recordings with several methods;
    validate; compare.

    ``study``: a :class:`~pinid.identification.study.Study` (``pinid.Study(model, data, validate=…, …)``, or
    ``Study.from_manifest(manifest, model)``), whose fields are these.
    ``model``: a RobotModel, URDF path or robot name.  ``data`` / ``validate``: Datasets or recording
    paths (read with :func:`pinid.data.formats.read_recording` and ``mapping``).  Recordings without ``dq`` or
    ``ddq`` go through :func:`pinid.data.preprocess.prepare` (see
    :func:`~pinid.problem.recordings.prepare_dataset` for ``preprocess``).
    ``methods``: names from :data:`pinid.estimators.ESTIMATORS` (default ols, wls, sdp).  ``terms``: the
    joint terms in the model (default Coulomb and viscous friction; ``"auto"``: chosen on the training
    recordings, :mod:`pinid.identification.term_choice`).  ``rest_velocity``,
    ``rest_fraction``: rows at rest dropped for Coulomb friction (:mod:`pinid.problem.problem`).
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
    ``fit_joints``: the joints whose torque rows enter the fit (``"J1,J2"`` or a list; default all): the
    others still move, are in the regressor's columns and are predicted and validated.  ``delay``: seconds by
    which the torque channels lag the positions (``0.04``, ``"tau.knee=0.04"``, ``"auto"``:
    :mod:`pinid.identification.delay`), in ``data["delay"]``.  A study read from a dataset manifest (:meth:`Study.from_manifest
    <pinid.identification.study.Study.from_manifest>`) has its path in ``data["manifest"]``.
    The runs' arguments: ``started``: called
    once the inputs are read and checked, before the first method runs (the CLI says what it identifies then, so
    that a bad input prints only its error).
    ``workers``: local processes fitting the methods in parallel (default 1: one after the other; None: every
    core); the numbers do not depend on it (:func:`~pinid.identification.runner.run_jobs`).
    ``truth``: the truth of a twin (``pinid simulate``'s ``run.truth.json``, its path or dict): every
    result gets ``truth_error``, its error against the true base parameters (:mod:`pinid.identification.truth`).
    Torque errors are against the torque as recorded (``result.validation``, ``result.train``) and after
    the preprocessing's low-pass (``validation_filtered``, ``train_filtered``).
    A floating-base ``model`` (``RobotModel.from_urdf(path, base="floating")``) is identified the same way from
    recordings with base motion and contact wrenches (docs/floating-base.md): ``floating``, a
    :class:`~pinid.identification.floating.FloatingOptions` or a mapping of its fields (the rows used, the base
    rows' weight, legs without force sensing); every row is kept unless ``rest_velocity`` is a speed; its
    errors are per body (``base``: the 6 wrench rows) against the prepared wrenches and torques.

    Returns an :class:`~pinid.identification.result.Identification`; ``result.model`` is the best
    result's :class:`~pinid.identification.identified.IdentifiedModel`, ``result["sdp"]`` one method's result.
    """
    t_start = time.perf_counter()
    if not isinstance(study, Study):
        raise SpecError(f"identify: got {type(study).__name__}, {EXPECTED_STUDY}")
    check_workers(workers)
    model, data, validate, terms, mapping = study.model, study.data, study.validate, study.terms, study.mapping
    preprocess, rest_velocity, payload, payload_data = (
        study.preprocess,
        study.rest_velocity,
        study.payload,
        study.payload_data,
    )
    fit_joints, delay, manifest, floating = study.fit_joints, study.delay, study.manifest, study.floating
    stribeck_velocity, stribeck_shape = study.stribeck_velocity, study.stribeck_shape
    if study.segmental is not None:
        raise SpecError("segmental: the seed-000 strategy of compare, not of identify")
    auto_spec = terms if parse_auto(terms) is not None else None  # chosen by the training data
    auto_terms, default_terms = auto_spec is not None, is_default(terms)
    terms = TermSelection() if auto_terms else as_terms(terms)
    methods = parse_methods(methods)
    options = check_options(options, methods)
    for m in methods:  # bad settings fail before any recording is read
        make_estimator(m, **options.get(m, {}))
    simulating = [m for m in methods if m in ("iv", "didim")] if study.offsets is not None else []
    if simulating:
        raise SpecError(
            f"{', '.join(simulating)} with offsets per recording: not supported (they simulate the recordings)"
        )
    if getattr(model, "base", "fixed") == "floating":
        return _identify_floating(
            replace(study, terms=terms),
            dict(methods=methods, options=options, complete=complete, show_progress=show_progress, started=started)
            | {"workers": workers},
            unsupported=dict(
                payload=payload,
                payload_data=payload_data,
                stribeck_velocity=stribeck_velocity,
                stribeck_shape=stribeck_shape,
                fit_joints=fit_joints,
                delay=delay,
                truth=truth,
                terms="auto" if auto_terms else None,
                offsets=study.offsets,
                calibrate_offsets=study.calibrate_offsets,
            ),
        )
    if floating is not None:
        raise SpecError(
            f"floating: {floating!r} given for {model.name}, a fixed-base robot (base='floating' loads it floating)"
        )
    if truth is not None:
        read_truth(truth)  # an unreadable truth fails before any recording is read
    settings, auto = stribeck_settings(model, terms, stribeck_velocity, stribeck_shape)
    if auto and payload is not None:
        raise SpecError("Stribeck velocity 'auto' with drive gains (--payload): give the velocity instead")
    model = model.with_stribeck(settings) if settings else model
    gains = None
    if payload is not None or payload_data is not None:
        gains, data, validate = _currents_to_torques(
            model, terms, data, validate, payload, payload_data, mapping, preprocess, rest_velocity
        )
        preprocess = False
    used = replace(
        study,
        model=model,
        data=data,
        validate=validate,
        terms=auto_spec if auto_terms else "default" if default_terms else terms,
        preprocess=preprocess,
        payload=None,
        payload_data=None,
    )
    s = setup(used, show_progress=show_progress, stribeck_auto=auto)
    model = s.model  # with the fitted Stribeck shapes (auto): built once, used from here on
    terms = s.terms  # chosen (auto, default) or left without the ripple terms when their periods' choice lost
    x_true = None if truth is None else true_base(truth, model, s.terms, s.base)  # checked before the fits
    ratio = check_recordings(s)
    if started is not None:
        started()
    jobs = [(m, None, options.get(m, {})) for m in methods]
    fits = _fit_jobs(s, jobs, ratio, complete=complete, show_progress=show_progress, workers=workers)
    results = {f.method: f.result for f in fits}
    del fits  # the estimators (wls: its row weights)
    if x_true is not None:
        for r in results.values():
            r.truth_error = truth_error(r.base, x_true, s.problem.natural_scale, s.base.names)
    summary, nominal = s.problem.summary(), s.base.shown(s.problem.nominal).tolist()
    scale = [float(v) for v in s.problem.natural_scale]  # the report's parameter figure
    s.problem = s.segmental = None  # its rows (torques, joints) let go before the predictions below
    values = {m: r.base for m, r in results.items()}
    val_sets, floor = s.validation.get("validation", []), None
    if val_sets:
        checked = [check_dataset(ds, model) for ds in val_sets]
        if s.offsets is not None:  # calibrated on each one's first fraction and scored on the rest, or not
            checked, preds, val_offsets = offset_validation(s.offsets, model, terms, s.base, checked, values)
        else:
            preds = [predict_torque(model, terms, s.base, ds, values) for ds in checked]
        tau_all = np.concatenate([ds.tau for ds in checked])
        recorded = np.concatenate([recorded_torque(ds) for ds in checked])
        units = joint_units(model)
        for m, r in results.items():
            pred = np.concatenate([p[m] for p in preds])
            r.validation = torque_metrics(recorded, pred, model.joint_names, units=units)
            r.validation_filtered = torque_metrics(tau_all, pred, model.joint_names, units=units)
        from pinid.identification.floor import validation_floor

        floor, floor_fit = validation_floor(model, terms, checked, offsets_per_recording=s.offsets is not None)
        summary["floor"] = floor_fit.to_dict()
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
        if s.offsets is not None:  # the first training recording's own offsets
            curves["predicted"] = {
                m: p + np.nan_to_num(s.offsets.offsets(values[m])[0]) for m, p in curves["predicted"].items()
            }
    if s.train:  # the training motion, drawn as the report's "excitation" figure
        ds = s.train[0]
        curves["motion"] = {"source": ds.source, "t": ds.t, "q": ds.q, "dq": ds.dq}
    if gains is not None:
        summary["drive_gains"] = gains.summary()
    if s.stribeck:
        summary["stribeck"] = s.stribeck
    if s.delay is not None:
        summary["delay"] = s.delay
    if s.cutoff is not None:
        summary["cutoff"] = s.cutoff
    if s.terms_choice is not None:  # the default terms' one test has a key of its own (no choices figure)
        default = str(s.terms_choice.get("chosen_by", "")).startswith("default")
        summary["default_terms" if default else "terms_choice"] = s.terms_choice
    if s.ripple is not None:
        summary["ripple_periods"] = s.ripple
    if s.sigmoid is not None:
        summary["sigmoid"] = s.sigmoid
    if manifest is not None:
        summary["manifest"] = str(manifest)
    if s.offsets is not None:
        summary["offsets"] = {"per_recording": s.offsets.sources, "calibrate_fraction": s.offsets.calibrate}
        for m, r in results.items():
            got = val_offsets[m] if val_sets else []
            sources = [d.source for d in checked] if val_sets else []
            r.info["offsets"] = offsets_summary(s.offsets, s.offsets.offsets(r.base), got, sources)
    fixed_total_mass(s, results, summary, nominal)  # where a fixed base's rows determine it (issue 46)
    return Identification(
        robot=robot_to_dict(model, terms),
        results=results,
        data=summary,
        base={
            "names": s.base.names,
            "expressions": s.base.expressions(),
            "nominal": nominal,
            "scale": scale,
        },
        validation_sources=[ds.source for ds in val_sets],
        seconds=time.perf_counter() - t_start,
        curves=curves,
        floor=floor,
    )


def _setup_floating(study: Study) -> Setup:
    """:func:`setup` of a floating-base robot (:mod:`pinid.identification.floating`): its recordings read, checked
    and prepared (base motion, contact wrenches; ``study.mapping``: a :class:`~pinid.data.mapping.MappingSpec` with its ``[floating]`` table),
    their 6 base rows stacked with the joint rows (:func:`~pinid.problem.floating.floating_problem`;
    ``study.floating``: the rows used, the base rows' weight, legs without force sensing), every row kept unless
    ``study.rest_velocity`` is a speed (the fixed base's "auto" validated worse: docs/floating-base.md), and the
    validation rows.  ``Setup.floating`` keeps what the fits' validation and checks read."""
    from pinid.data.mapping import MappingSpec
    from pinid.data.preprocess import Preprocessing
    from pinid.identification.calibration import fit_calibration
    from pinid.identification.floating import FloatingStack, as_floating_options, recording_hints, refuse_fixed_only
    from pinid.identification.floating import rows_without_torque
    from pinid.identification.floating_checks import (
        cop_offset_warning,
        flipped_floating_signs,
        orientation_noise_warning,
    )
    from pinid.identification.plausibility import shared_excitation
    from pinid.model.floating import as_floating
    from pinid.problem.floating import floating_problem

    fixed_only = ("segmental", "payload", "payload_data", "stribeck_velocity", "stribeck_shape")
    refuse_fixed_only(
        {k: getattr(study, k) for k in (*fixed_only, "fit_joints", "delay")}
        | {"terms": "auto" if parse_auto(study.terms) is not None else None}
    )  # identify and compare refuse theirs first, with their own arguments: this is for setup's own callers
    model, terms, opts = as_floating(study.model), as_terms(study.terms), as_floating_options(study.floating)
    preprocess, mapping, validate = study.preprocess, study.mapping, study.validate
    if isinstance(preprocess, Mapping) and isinstance(preprocess.get("cutoff"), str):  # the dict form: Study's
        raise SpecError(
            "cut-off auto: not available with a floating base (docs/floating-base.md); give a frequency [Hz]"
        )
    if isinstance(model.setting("ripple_periods"), str):  # "auto": periods are numbers
        raise SpecError("ripple periods auto: not available with a floating base; give the periods")
    if isinstance(model.setting("sigmoid"), str):
        raise SpecError("sigmoid shape auto: not available with a floating base; give the shape")
    if isinstance(validate, Mapping):  # {label: recordings}: one set with a floating base
        if set(validate) - {"validation"}:
            raise SpecError(f"validate: sets {', '.join(map(str, validate))}; a floating base takes one set")
        validate = validate.get("validation")
    rest = None if isinstance(study.rest_velocity, str) else study.rest_velocity
    mapping = None if mapping is None else MappingSpec.load(mapping)  # checked once, before any recording is read
    hints: list[str] = []  # convention errors the raw training recordings point to (recording_hints)

    glitches = _glitch_check(model)
    motion_capture: list[bool] = []  # per raw training recording: its base orientation is the motion capture's

    def check(rec, found: list | None = None) -> None:  # each raw recording: its conventions, orientation noise
        glitches(rec)
        if found is None:
            motion_capture.append(rec.floating is not None and rec.floating.base_pose is not None)
        (hints if found is None else found).extend(recording_hints(rec, model))
        orientation_noise_warning(rec, Preprocessing.normalize(preprocess), rec.source)

    load = dict(swing_rows=opts.swing_rows)
    train = load_datasets(study.data, model, mapping, preprocess, check=check, **load)
    opts = rows_without_torque(opts, train)  # no joint torque: the base rows, said in one line
    calibration = fit_calibration(model, train, opts.calibration, motion_capture=all(motion_capture))
    train = calibration.apply(train)  # the same calibration for the validation recordings, below
    # the joint torques' sign and scale, and the plates' centres of pressure, are judged against the measured
    # wrenches: not when the raw recordings already doubt those (hints name the cause instead)
    found: dict = {}
    flipped = flipped_floating_signs(model, train, found=found) if opts.rows != "base" and not hints else []
    if not hints:
        cop_offset_warning(model, train, ", ".join(s.source for s in train))
    rows = dict(rows=opts.rows, base_weight=opts.base_weight, rest_velocity=rest)
    problem = floating_problem(model, train, terms=terms, **rows)
    val, val_problem, sources = [], None, ", ".join(s.source for s in train)
    if validate:
        val = load_datasets(validate, model, mapping, preprocess, "validation", check=lambda r: check(r, []), **load)
        val = calibration.apply(val)
        shared_excitation([r.data for r in train], [r.data for r in val])  # a repeat hides overfitting: warned
        val_problem = floating_problem(model, val, terms=problem.terms, base=problem.base, **rows)
    if not np.any(np.abs(problem.tau) > 1e-9 * max(1.0, float(np.max(np.abs(problem.tau), initial=0.0)))):
        raise DataError(
            f"{sources}: no external wrench and no joint torque in the rows used ({opts.rows}): they are "
            "homogeneous (W·θ = 0) and identify nothing; expected wrench_<link>_* or plate_<link>_* columns (the "
            "wrench applied by the environment on the robot) or joint torques with --rows all"
        )
    stack = FloatingStack(
        problem,
        val_problem,
        train,
        val,
        hints,
        flipped,
        sources,
        torque_scale=found.get("torque_scale"),
        calibration=calibration,
        rows=opts.rows,
    )
    validation = {"validation": [s.data for s in val]} if val_problem is not None else {}
    return Setup(model, problem.terms, problem.base, problem, [s.data for s in train], validation, floating=stack)


def _identify_floating(study: Study, running: dict, *, unsupported: dict) -> Identification:
    """:func:`identify` of a floating-base robot: its recordings and rows (:func:`setup`), then the fixed base's
    fits, results and checks (:mod:`pinid.identification.floating`)."""
    from pinid.identification.floating import as_floating_options, check_floating, refuse_fixed_only, validate_floating

    refuse_fixed_only(unsupported)
    t_start, opts, model = time.perf_counter(), as_floating_options(study.floating), study.model
    s = setup(study)
    run, problem = s.floating, s.problem
    if running["started"] is not None:
        running["started"]()
    jobs = [(m, None, running["options"].get(m, {})) for m in running["methods"]]
    fits = _fit_jobs(
        s,
        jobs,
        run.torque_scale,
        complete=running["complete"],
        show_progress=running["show_progress"],
        workers=running["workers"],
    )
    results = {f.method: f.result for f in fits}
    del fits
    floor = validate_floating(run, results)
    ds = run.train[0].data
    ident = Identification(
        robot=robot_to_dict(model, problem.terms),
        results=results,
        data=problem.summary()
        | {
            "base": "floating",
            "rows": run.rows,
            "base_weight": opts.base_weight,
            "rows_per_sample": int(problem.rows // max(problem.samples, 1)),
        }
        | (
            {"calibration": run.calibration.to_dict(), "calibration_text": run.calibration.text()}
            if run.calibration is not None
            else {}
        ),
        base={
            "names": problem.names,
            "expressions": problem.base.expressions(),
            "nominal": problem.base.shown(problem.nominal).tolist(),
            "scale": [float(v) for v in problem.natural_scale],
        },
        validation_sources=[] if run.validation is None else list(run.validation.sources),
        curves={"motion": {"source": ds.source, "t": ds.t, "q": ds.q, "dq": ds.dq}},
        floor=floor,
    )
    check_floating(run, ident, model, run.rows)  # and the floating figures' traces, each axis's error
    ident.seconds = time.perf_counter() - t_start
    return ident


def check_recordings(s: Setup, samples: int = 5000) -> float | None:
    """The one-line warnings of :mod:`pinid.identification.plausibility` (``identify`` and ``compare``): a
    validation recording that repeats a training trajectory; a torque channel whose sign is flipped against
    the URDF's torque (rigid bodies and the URDF's friction, on at most ``samples`` samples of the training
    recordings), torques whose scale is far from it (their units).  Returns that scale
    (:func:`~pinid.identification.plausibility.torque_scale`)."""
    if not isinstance(s, Setup):
        raise SpecError(f"s: got {type(s).__name__}, expected the Setup of pinid.identification.run.setup")
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise SpecError(f"samples: got {samples!r}, expected a whole number ≥ 1")
    from pinid.identification.plausibility import flipped_torque_signs, shared_excitation, torque_scale

    model = s.model
    train = [check_dataset(ds, model) for ds in s.train]
    held_out = [check_dataset(ds, model) for sets in s.validation.values() for ds in sets]
    shared_excitation(train, held_out)
    step = max(1, sum(ds.n for ds in train) // samples)
    q, dq, ddq, tau = (np.concatenate([getattr(ds, k)[::step] for ds in train]) for k in ("q", "dq", "ddq", "tau"))
    nominal = model.rnea(q, dq, ddq) + model.coulomb * np.sign(dq) + model.viscous * dq
    flipped_torque_signs(model.joint_names, tau, nominal)
    return torque_scale(model.joint_names, tau, nominal, ", ".join(ds.source for ds in train))


def _fit_jobs(s: Setup, jobs: list, ratio: float | None, **run) -> list:
    """:func:`~pinid.identification.runner.run_jobs`; when the torques' scale is far off the URDF's (``ratio``,
    :func:`~pinid.identification.plausibility.torque_scale`) and a solver fails, each method is fitted alone and
    those whose solver fails are left out with one warning naming the scale (OLS still comes out); SolverError
    naming it when none comes out."""
    from pinid.errors import DataWarning, SolverError
    from pinid.identification.plausibility import TORQUE_SCALE

    try:
        return run_jobs(s, jobs, **run)
    except SolverError as exc:
        if ratio is None or TORQUE_SCALE[0] <= ratio <= TORQUE_SCALE[1]:
            raise
        first = exc
    cause = f"likely cause: the torques' scale, {ratio:.3g} × the URDF's torque for this motion (their units)"
    fits = []
    for job in jobs:
        try:
            fits += run_jobs(s, [job], **run)
        except SolverError as exc:
            warnings.warn(f"{exc}: {job[0]} left out; {cause}", DataWarning, stacklevel=3)
    if not fits:
        raise SolverError(f"{first}; {cause}") from None
    return fits


def _glitch_check(model) -> Callable:
    """The raw-recording check of :func:`load_datasets` that names an encoder glitch
    (:func:`pinid.identification.plausibility.position_glitches`)."""
    from pinid.identification.plausibility import position_glitches

    limit, units = model.velocity_limit, ["m" if u == "N" else "rad" for u in joint_units(model)]
    return lambda ds: position_glitches(ds, limit, units)


def _currents_to_torques(model, terms, data, validate, payload, payload_data, mapping, preprocess, rest_velocity):
    """``(gains, training, validation)``: drive gains from the recordings with and without the payload, and
    the recordings' currents turned into torques (see :mod:`pinid.identification.gains`)."""
    from pinid.identification.gains import Payload, check_payload, identify_gains

    if payload is None or payload_data is None:
        raise SpecError(
            "drive gains need both the payload (--payload FILE) and a recording with it (--payload-data FILE)"
        )
    if isinstance(payload, Mapping):
        payload = Payload.from_dict(payload, "payload")
    elif isinstance(payload, (str, os.PathLike)):
        payload = Payload.load(payload)
    elif not isinstance(payload, Payload):
        raise SpecError(
            f"payload: got {type(payload).__name__}, expected a Payload, its table (a dict) or a payload TOML file"
        )
    check_payload(payload, model)
    check_distinct(payload_data, what="payload data")
    check_payload_data_distinct(data, payload_data)
    train = load_datasets(data, model, mapping, preprocess, "training")
    loaded = load_datasets(payload_data, model, mapping, preprocess, "payload")
    check_payload_data_distinct(train, loaded)
    gains = identify_gains(model, train, loaded, payload, terms=terms, rest_velocity=rest_velocity)

    def torques(items, what):
        return [gains.apply(ds) for ds in load_datasets(items, model, mapping, preprocess, what)]

    if isinstance(validate, Mapping):
        validate = {k: torques(v, f"validation ({k})") for k, v in validate.items()}
    elif validate is not None:
        validate = torques(validate, "validation")
    return gains, [gains.apply(ds) for ds in train], validate
