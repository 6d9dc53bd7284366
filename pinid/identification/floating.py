"""Identify a floating-base robot from recordings with base motion and contact wrenches (``pinid identify
--base floating``): read, prepare, stack (:mod:`pinid.problem.floating`), fit every method,
validate, and write ``identification.json`` and the identified URDFs and MJCFs of consistent results."""

from __future__ import annotations

import os
import time
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pinid.data.contacts import FloatingSamples, floating_mapping, prepare_floating, read_floating
from pinid.errors import DataError, ModelError, SpecError
from pinid.estimators import make_estimator
from pinid.problem.floating import floating_problem
from pinid.io import Artefacts, write_json
from pinid.model.floating import FloatingRobotModel, as_floating, floating_parameter_names, floating_urdf
from pinid.model.serialize import robot_from_dict, robot_to_dict
from pinid.model.mjcf import identified_mjcf
from pinid.model.terms import TermSelection, as_terms
from pinid.identification.floating_checks import (
    com_warning,
    excitation_warning,
    flipped_floating_signs,
    method_statistics,
    orientation_noise_warning,
    parameters_text,
    std_percent,
)
from pinid.identification.plausibility import shared_excitation


@dataclass
class FloatingIdentification:
    """Every method's base (and, when it fits them, standard) parameters, training and validation RMS per row
    (base rows by force/moment component, joint rows by joint) [N, N·m]."""

    robot: str
    rows: str
    names: list[str]
    nominal: np.ndarray
    results: dict[str, dict] = field(default_factory=dict)
    data: dict = field(default_factory=dict)
    #: The robot and terms (:func:`pinid.model.serialize.robot_to_dict`, URDF text included): what
    #: ``pinid export`` rebuilds the model from.
    model: dict | None = None

    def to_dict(self) -> dict:
        return {
            "robot": self.robot,
            "base": "floating",
            "rows": self.rows,
            "base_parameter_names": self.names,
            "nominal_base": self.nominal.tolist(),
            "data": self.data,
            "results": self.results,
            **({"model": self.model} if self.model is not None else {}),
        }

    def text(self, *, verbose: bool = False) -> str:
        """A table of each method's RMS, cond(W_b) and total mass; each method's largest relative standard
        deviation (``verbose``: every base parameter's value, σ and σ %)."""
        out = [f"{'method':<8}{'train RMS':>12}{'valid. RMS':>12}{'cond(W_b)':>11}{'seconds':>10}   total mass [kg]"]
        for m, r in self.results.items():
            val = "-" if r["validation_rms"] is None else f"{r['validation_rms']:.4g}"
            mass = r["base"][0] if self.names[0].startswith("base.m") else float("nan")
            cond = r.get("condition_number", float("nan"))
            out.append(f"{m:<8}{r['train_rms']:>12.4g}{val:>12}{cond:>11.4g}{r['seconds']:>10.3f}   {mass:.6g}")
        for m, r in self.results.items():
            out += parameters_text(m, self.names, r, verbose=verbose)
        floor = self.data.get("floor")
        if floor:
            best = min(self.results, key=lambda m: self.results[m]["validation_rms"])
            by = self.results[best]["validation_rms_by_row"]
            cells = [f"all {floor['rms']:.3g} ({best} {self.results[best]['validation_rms']:.3g})"]
            cells += [f"{k} {v:.3g} ({best} {by[k]:.3g})" for k, v in floor["rms_by_row"].items() if k in by]
            out.append(
                "model-class floor, valid. RMS [N·m; base: N and N·m] (the same terms fitted by OLS on the "
                f"validation recording itself): {', '.join(cells)}; near the floor the model class limits the "
                "result, far above it the identification"
            )
        return "\n".join(out)


def load_floating(
    items,
    model: FloatingRobotModel,
    preprocess=None,
    what: str = "training",
    *,
    swing_rows: bool = False,
    mapping=None,
    hints: list[str] | None = None,
) -> list[FloatingSamples]:
    """Floating recordings (paths or prepared :class:`FloatingSamples`) read, checked and prepared
    (``swing_rows``: accept contact phases without a wrench; ``mapping``: a mapping spec with a ``[floating]``
    table for files not in the dataset format, :func:`pinid.data.contacts.read_floating`; ``hints``: a list
    :func:`recording_hints` appends to; motion-capture orientation noise that biases at the default cut-off is
    warned, :func:`~pinid.identification.floating_checks.orientation_noise_warning`)."""
    if items is None:
        return []
    if isinstance(items, (FloatingSamples, str, os.PathLike)):
        items = [items]
    out = []
    for item in items:
        if isinstance(item, FloatingSamples):
            out.append(item)
        elif isinstance(item, (str, os.PathLike)):
            rec = read_floating(item, model, swing_rows=swing_rows, mapping=mapping)
            found = recording_hints(rec, model)
            if hints is not None:
                hints.extend(found)
            orientation_noise_warning(rec, preprocess, str(item))
            out.append(prepare_floating(rec, model, preprocess))
        else:
            raise DataError(f"{what} recording: got {type(item).__name__}, expected a path or FloatingSamples")
    if not out:
        raise DataError(f"no {what} recording given")
    return out


def identify_floating(
    model: FloatingRobotModel,
    data,
    *,
    methods: Sequence[str] = ("ols", "sdp"),
    validate=None,
    terms: TermSelection = TermSelection(),
    rows: str = "all",
    base_weight: float = 1.0,
    preprocess: Mapping | bool | None = None,
    options: Mapping[str, Mapping] | None = None,
    swing_rows: bool = False,
    rest_velocity=None,
    mapping=None,
) -> FloatingIdentification:
    """Fit every method on the training recordings and score it on the validation ones (RMS over the rows used).
    ``swing_rows``: links with contact phases but no wrench are legs without force sensing; the rows their
    unknown wrench enters are left out while they are in contact.  ``rest_velocity``: as
    :func:`~pinid.problem.floating.floating_problem` (None keeps every row).  ``mapping``: how
    to read recordings not in the dataset format (:func:`pinid.data.contacts.floating_mapping`)."""
    model = as_floating(model)
    terms = as_terms(terms)
    if mapping is not None:
        mapping = floating_mapping(mapping)  # checked once, before any recording is read
    hints: list[str] = []  # convention errors the raw recordings point to (recording_hints)
    train = load_floating(data, model, preprocess, swing_rows=swing_rows, mapping=mapping, hints=hints)
    flipped = flipped_floating_signs(model, train) if rows != "base" else []  # one warning, as a fixed base's
    problem = floating_problem(
        model, train, terms=terms, rows=rows, base_weight=base_weight, rest_velocity=rest_velocity
    )
    val_problem = None
    if validate:
        val = load_floating(validate, model, preprocess, "validation", swing_rows=swing_rows, mapping=mapping)
        shared_excitation([r.data for r in train], [r.data for r in val])  # a repeat hides overfitting: warned
        val_problem = floating_problem(
            model,
            val,
            terms=problem.terms,
            rows=rows,
            base_weight=base_weight,
            base=problem.base,
            rest_velocity=rest_velocity,
        )
    if not np.any(np.abs(problem.tau) > 1e-9 * max(1.0, float(np.max(np.abs(problem.tau), initial=0.0)))):
        raise DataError(
            f"{_sources(data)}: no external wrench and no joint torque in the rows used ({rows}): they are "
            "homogeneous (W·θ = 0) and identify nothing; expected wrench_<link>_* or plate_<link>_* columns (the "
            "wrench applied by the environment on the robot) or joint torques with --rows all"
        )
    ident = FloatingIdentification(model.name, rows, problem.names, problem.nominal_base)
    ident.model = robot_to_dict(model, problem.terms)
    ident.data = problem.summary() | {"rows_per_sample": int(problem.rows // max(problem.samples, 1))}
    ident.data["flipped_torque_signs"] = flipped
    for method in methods:
        start = time.perf_counter()
        est = make_estimator(method, **dict((options or {}).get(method, {}))).fit(problem)
        seconds = time.perf_counter() - start
        r = problem.tau - problem.predict(est.base_)
        std, cond = method_statistics(problem, est, r)
        entry = {
            "base": est.base_.tolist(),
            "std": std.tolist(),
            "std_percent": dict(zip(problem.names, std_percent(est.base_, std).tolist())),
            "condition_number": cond,
            "standard": None if getattr(est, "standard_", None) is None else np.asarray(est.standard_).tolist(),
            "standard_names": problem.standard_names,
            "standard_marks": problem.base.marks(),
            "train_rms": float(np.sqrt(np.mean(r * r))),
            "train_rms_by_row": _by_row(problem, r),
            "validation_rms": None,
            "seconds": seconds,
        }
        if val_problem is not None:
            rv = val_problem.tau - val_problem.predict(est.base_)
            entry["validation_rms"] = float(np.sqrt(np.mean(rv * rv)))
            entry["validation_rms_by_row"] = _by_row(val_problem, rv)
        ident.results[method] = entry
    if val_problem is not None:
        ident.data["floor"] = _floor(val_problem)
    _check_total_mass(ident, hints, _sources(data))
    excitation_warning(ident, problem.natural_scale, _sources(data))
    if rows != "joints":
        posture = np.mean(np.concatenate([s.data.q for s in train]), axis=0)
        com_warning(ident, model, problem.terms, problem.base, posture, _sources(data))
    return ident


#: identified total mass / the URDF's: outside this band a warning, outside ``MASS_REFUSED`` (or ≤ 0 for every
#: method) an error: nothing sensible can come out of such a recording (docs/floating-base.md)
MASS_WARNED = (0.5, 2.0)
MASS_REFUSED = (0.2, 5.0)


def _sources(data) -> str:
    items = [data] if isinstance(data, (str, os.PathLike, FloatingSamples)) else list(data or [])
    names = [str(d) if isinstance(d, (str, os.PathLike)) else d.data.source for d in items]
    return ", ".join(names) or "floating recording"


def recording_hints(rec, model: FloatingRobotModel) -> list[str]:
    """What in a raw floating recording points to a convention error, one phrase each: contact phases that are 0
    (not in contact) on most samples where the measured force exceeds half the robot's weight (phase logic
    inverted), an accelerometer whose mean specific force is far below g (gravity left out), base positions
    beyond 20 m (millimetres), a quaternion whose x is near ±1 on average (w first: an upright robot's w read as
    x).  Each is also warned about at once (one line)."""
    weight = sum(float(i.mass) for i in model.ff_model.inertias) * 9.81
    src, hints = rec.source, []
    for link, phase in rec.contacts.items():
        w = rec.wrenches.get(link, rec.plates.get(link))
        off = ~np.asarray(phase, bool)
        loaded = np.linalg.norm(w[:, :3], axis=1) > 0.5 * weight if w is not None else np.zeros(0, bool)
        if loaded.any() and np.mean(off[loaded]) > 0.5:
            hints.append(
                f"{src}: contact_{link} is 0 on {np.mean(off[loaded]):.0%} of the samples where the force on "
                f"'{link}' exceeds half the robot's weight: check the phase logic (1 = in contact)"
            )
            warnings.warn(hints[-1], stacklevel=3)
    if "a" in rec.imu and np.mean(np.linalg.norm(rec.imu["a"], axis=1)) < 0.3 * 9.81:
        hints.append(
            f"{src}: the accelerometer's mean |a| is {np.mean(np.linalg.norm(rec.imu['a'], axis=1)):.3g} m/s²: it "
            "must include gravity (an IMU measures specific force, about 9.81 m/s² at rest)"
        )
        warnings.warn(hints[-1], stacklevel=3)
    if rec.base_pose is not None and np.max(np.abs(rec.base_pose[:, :3])) > 20:
        top = np.max(np.abs(rec.base_pose[:, :3]))
        hints.append(f"{src}: base positions up to {top:.4g}: units (m expected, not mm)")
        warnings.warn(hints[-1], stacklevel=3)
    for what, q in (("base", None if rec.base_pose is None else rec.base_pose[:, 3:]), ("IMU", rec.imu.get("q"))):
        # read as x, y, z, w, a w-first stream of a robot that stands upright has its w in the x column
        if q is not None and np.mean(np.abs(q[:, 0])) > 0.7:
            hints.append(
                f"{src}: the {what} quaternion's x is near ±1 (upside down?): quaternion order (x, y, z, w "
                "expected, w last)"
            )
            warnings.warn(hints[-1], stacklevel=3)
    return hints


def _check_total_mass(ident: FloatingIdentification, hints: list[str], source: str) -> None:
    """Warn when a method's total mass is outside ``MASS_WARNED`` × the URDF's, refuse (DataError) when every
    method's is outside ``MASS_REFUSED`` × or negative, naming the likely cause."""
    if not ident.names or ident.names[0] != "base.mR" or ident.rows == "joints":
        return
    nominal = float(ident.nominal[0])
    masses = {m: float(r["base"][0]) for m, r in ident.results.items()}
    if nominal <= 0 or not masses:
        return
    odd = {m: v for m, v in masses.items() if not MASS_WARNED[0] <= v / nominal <= MASS_WARNED[1]}
    if not odd:
        return
    text = ", ".join(f"{m} {v:.4g} kg" for m, v in odd.items())
    cause = "; ".join(hints) or (
        "the sign of the wrench (pinid wants the wrench applied BY the environment ON the robot; force plates "
        "usually give the opposite)"
        if min(odd.values()) < 0
        else "the sign or units of the wrench, the contact phases (1 = in contact) or the units of the base pose"
    )
    line = f"{source}: identified total mass {text} against the URDF's {nominal:.4g} kg; likely cause: {cause}"
    if len(odd) == len(masses) and all(not MASS_REFUSED[0] <= v / nominal <= MASS_REFUSED[1] for v in odd.values()):
        raise DataError(line)
    warnings.warn(line, stacklevel=3)


def _floor(problem) -> dict | None:
    """The model-class floor (:mod:`pinid.identification.floor`): OLS fitted on the validation rows themselves
    and its RMS over them, all rows and per body (``base``: the 6 wrench rows) [N·m, N]; None when they do not
    determine the parameters alone."""
    try:
        r = problem.tau - problem.predict(make_estimator("ols").fit(problem).base_)
    except (np.linalg.LinAlgError, DataError, ValueError):
        return None
    return {"rms": float(np.sqrt(np.mean(r * r))), "rms_by_row": _by_row(problem, r)}


def _by_row(problem, r: np.ndarray) -> dict[str, float]:
    """RMS of the residual per body (the 6 base rows together as ``base``) [N·m, or N and N·m mixed for base]."""
    names = problem.model.joint_names
    return {names[j]: float(np.sqrt(np.mean(r[problem.joint == j] ** 2))) for j in np.unique(problem.joint)}


def write_floating_identification(
    ident: FloatingIdentification,
    folder: str | os.PathLike,
    model: FloatingRobotModel | None = None,
    terms: TermSelection = TermSelection(),
) -> list[Path]:
    """Write ``identification.json`` into ``folder`` and, with ``model``, ``identified_<method>.urdf`` and the
    MuJoCo MJCF ``identified_<method>.xml`` (a free joint on the base link, :func:`pinid.model.mjcf.identified_mjcf`;
    a warning instead when MuJoCo would refuse a body) for every method that fits physically consistent standard
    parameters (sdp): all or nothing
    (:class:`pinid.io.Artefacts`).  ``terms``: those of the identification."""
    from pinid.model.physical import check_consistency

    folder = Path(folder)
    arts = Artefacts()
    arts.add(folder / "identification.json", lambda p: write_json(p, ident.to_dict()))
    if model is not None:
        terms = as_terms(terms)
        for method, r in ident.results.items():
            theta = r.get("standard")
            if theta is None or len(theta) != len(r["standard_names"]):
                continue
            theta = np.asarray(theta)
            if not check_consistency(theta, model.body_names, terms.names, []).consistent:
                continue
            arts.add(
                folder / f"identified_{method}.urdf",
                lambda p, th=theta, m=method, mk=r.get("standard_marks"): floating_urdf(
                    model, th, terms, p, comment=m, marks=mk
                ),
            )
            try:  # computed now: a body MuJoCo refuses (massless, a zero moment) costs the MJCF only
                text = identified_mjcf(
                    model, theta, terms, comment=f"method {method}", floating=True, marks=r.get("standard_marks")
                )
            except ModelError as exc:
                warnings.warn(f"no MJCF for {method}: {exc}", stacklevel=2)
                continue
            arts.add(folder / f"identified_{method}.xml", text)
    return arts.write()


def load_floating_identified(
    path: str | os.PathLike, *, method: str | None = None
) -> tuple[FloatingRobotModel, TermSelection, np.ndarray, str]:
    """The floating robot, its terms, the standard parameters (``base.*`` first) and the method of a floating
    identification (``identification.json`` of ``pinid identify --base floating``): ``method``, or by default
    the physically consistent method with the lowest validation (else training) RMS.  SpecError naming the
    file when it has no robot description or no such result."""
    from pinid.io import read_json
    from pinid.model.physical import check_consistency

    d = read_json(path, "floating identification")
    if not isinstance(d, dict) or d.get("base") != "floating" or not isinstance(d.get("results"), dict):
        raise SpecError(f"{path}: not a floating identification (pinid identify --base floating)")
    if not isinstance(d.get("model"), dict):
        raise SpecError(f"{path}: no robot description ('model'); identify again with this version of pinid")
    try:
        model, terms = robot_from_dict(d["model"])
    except SpecError as exc:
        raise SpecError(f"{path}: {exc}") from None
    model = as_floating(model)
    try:
        expected = floating_parameter_names(model, terms)
    except (ModelError, SpecError) as exc:
        raise SpecError(f"{path}: 'model': {exc}") from None
    usable = {}
    for m, r in d["results"].items():
        theta = _standard_of(path, m, r, expected)
        if theta is not None and check_consistency(theta, model.body_names, terms.names, []).consistent:
            usable[m] = (theta, r.get("validation_rms") or r.get("train_rms") or np.inf)
    if method is not None:
        if method not in d["results"]:
            raise SpecError(f"{path}: no method '{method}' (methods: {', '.join(d['results'])})")
        if method not in usable:
            raise SpecError(
                f"{path}: method '{method}' has no physically consistent standard parameters (identify with sdp)"
            )
    elif not usable:
        raise SpecError(f"{path}: no method with physically consistent standard parameters (identify with sdp)")
    else:
        method = min(usable, key=lambda m: usable[m][1])
    return model, terms, usable[method][0], method


def _standard_of(path, method: str, r, expected: list[str]) -> np.ndarray | None:
    """The standard parameters of one result of a floating identification file, in the order of ``expected``
    (the model's names), matched by name; None when the method fits none (``standard`` null) or they are not
    finite.  SpecError naming the file, the method and the field when the file does not say them properly."""
    where = f"{path}: results.{method}"
    if not isinstance(r, Mapping):
        raise SpecError(f"{where}: expected an object, got {type(r).__name__}")
    values, names = r.get("standard"), r.get("standard_names")
    if values is None:
        return None
    if not isinstance(values, list) or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
        raise SpecError(f"{where}.standard: expected a list of numbers")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise SpecError(f"{where}.standard_names: expected a list of parameter names")
    if len(values) != len(names):
        raise SpecError(f"{where}: {len(values)} standard values for {len(names)} standard_names")
    if len(set(names)) != len(names):
        raise SpecError(f"{where}.standard_names: a name appears twice")
    missing = [n for n in expected if n not in set(names)]
    extra = [n for n in names if n not in set(expected)]
    if missing or extra:
        said = "; ".join(
            f"{label} {', '.join(ns[:3])}{' …' if len(ns) > 3 else ''}"
            for label, ns in (("missing", missing), ("unknown", extra))
            if ns
        )
        raise SpecError(
            f"{where}.standard_names do not match the {len(expected)} parameters of the file's model and "
            f"terms ('model'): {said}"
        )
    by_name = dict(zip(names, values))
    theta = np.array([float(by_name[n]) for n in expected])
    return theta if np.all(np.isfinite(theta)) else None


def floating_marks(path: str | os.PathLike, method: str) -> dict[str, str] | None:
    """``{standard name: mark}`` of ``method`` in a floating ``identification.json`` (which standard parameters
    the data determined, :meth:`pinid.model.base.BaseParameters.marks`); None when the file has none (an older
    pinid) or they do not match its standard names."""
    from pinid.io import read_json
    from pinid.model.base import MARKS

    r = (read_json(path, "floating identification").get("results") or {}).get(method)
    marks = r.get("standard_marks") if isinstance(r, dict) else None
    names = r.get("standard_names") if isinstance(r, dict) else None
    if not isinstance(marks, dict) or not isinstance(names, list) or set(marks) != set(names):
        return None
    return dict(marks) if set(marks.values()) <= set(MARKS) else None
