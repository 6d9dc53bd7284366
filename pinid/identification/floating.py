"""The floating base in the one pipeline (``pinid identify --base floating``, :func:`pinid.identification.run.identify`
with a :class:`~pinid.model.floating.FloatingRobotModel`): a free flyer is a root joint, as in Pinocchio.

What differs from a fixed base lives here and nowhere else: the convention errors a raw recording points to
(:func:`recording_hints`, run by :func:`pinid.identification.run.setup` on each recording the one loader,
:func:`pinid.problem.recordings.load_datasets`, reads and prepares for a floating model), stacking the 6 base rows
with the joint rows (:func:`pinid.problem.floating.floating_problem`; :class:`FloatingOptions`), the validation rows, and the
checks a floating recording needs (total mass, whole-body centre of mass, barely excited parameters, the
convention errors a raw recording points to).  Fitting, σ, condition number, consistency, completion, the
result (:class:`~pinid.identification.result.Identification`), its files, report and
:class:`~pinid.identification.identified.IdentifiedModel` are the fixed base's own."""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pinid.data.contacts import FloatingSamples
from pinid.errors import DataError, SpecError
from pinid.estimators import make_estimator
from pinid.identification.floating_checks import EXCITED_FRACTION, com_warning, excitation_warning
from pinid.identification.floating_checks import total_mass_combination
from pinid.identification.mass import mass_and_com
from pinid.identification.metrics import TorqueMetrics, error_metrics, joint_units
from pinid.io import read_json
from pinid.model.floating import FloatingRobotModel
from pinid.problem.problem import IdentificationProblem

#: The rows a floating identification fits (:func:`pinid.model.floating.row_mask`).
ROWS = ("all", "base", "joints")


@dataclass(frozen=True)
class FloatingOptions:
    """How a floating base's rows are stacked: ``rows`` (``all``: the 6 base rows and the joint rows; ``base``: the
    base rows alone, no joint torque needed; ``joints``), ``base_weight`` (the base rows' weight against the
    joint rows, in [1e-6, 1e6]: checked where the rows are stacked), ``swing_rows`` (links with contact phases but no measured wrench are legs without force sensing:
    the rows their unknown wrench enters are left out while they are in contact), ``calibration`` (the sensor
    calibration: ``"auto"`` chosen by the data, ``"none"``, or terms such as ``"offsets,tilt"``:
    :mod:`pinid.identification.calibration`)."""

    rows: str = "all"
    base_weight: float = 1.0
    swing_rows: bool = False
    calibration: object = "auto"

    def __post_init__(self) -> None:
        from pinid.model.calibration import calibration_names

        calibration_names(self.calibration)  # SpecError for an unknown term
        if self.rows not in ROWS:
            raise SpecError(f"rows: got {self.rows!r}, expected one of {', '.join(ROWS)}")
        if isinstance(self.base_weight, bool) or not isinstance(self.base_weight, (int, float)):
            raise SpecError(f"base_weight: got {type(self.base_weight).__name__}, expected a number")
        if not isinstance(self.swing_rows, bool):
            raise SpecError(f"swing_rows: got {type(self.swing_rows).__name__}, expected True or False")


#: The command-line option of a study argument whose name is not the option's (the rest: ``--name-with-dashes``).
_OPTIONS = {"segmental": "--first-data", "terms": "--terms auto"}


def rows_without_torque(opts: FloatingOptions, train) -> FloatingOptions:
    """``opts`` with the base rows when every training recording lacks joint torque and the rows are ``all`` (the
    default), said in one line (a legged robot's lab records no joint torque); ``opts`` otherwise (``joints``
    without torque is refused where the rows are stacked)."""
    from dataclasses import replace

    from pinid.errors import DataWarning

    if opts.rows != "all" or not train or any(r.data.tau is not None for r in train):
        return opts
    warnings.warn(
        f"{', '.join(r.source for r in train)}: no joint torque (tau_<joint> columns): the 6 base rows alone are "
        "used (rows='base', --rows base: contact wrenches and motion)",
        DataWarning,
        stacklevel=3,
    )
    return replace(opts, rows="base")


def refuse_fixed_only(arguments: Mapping) -> None:
    """SpecError naming every argument of ``arguments`` (``{name: value}``) that is given (not None or False): options
    of a fixed base a floating one does not take, named as in Python and on the command line."""
    if not isinstance(arguments, Mapping):
        raise SpecError(f"arguments: got {type(arguments).__name__}, expected a mapping of argument names to values")
    given = [k for k, v in arguments.items() if v is not None and v is not False]
    if given:
        named = ", ".join(f"{k} ({_OPTIONS.get(k, '--' + k.replace('_', '-'))})" for k in given)
        raise SpecError(f"{named}: not available with a floating base (docs/floating-base.md)")


def as_floating_options(value) -> FloatingOptions:
    """``value`` as :class:`FloatingOptions` (None: the defaults; a mapping of its fields)."""
    if value is None:
        return FloatingOptions()
    if isinstance(value, FloatingOptions):
        return value
    if isinstance(value, Mapping):
        unknown = [k for k in value if k not in ("rows", "base_weight", "swing_rows", "calibration")]
        if unknown:
            raise SpecError(
                f"floating: unknown option(s) {', '.join(map(str, unknown))} (rows, base_weight, swing_rows, "
                "calibration)"
            )
        return FloatingOptions(**value)
    raise SpecError(f"floating: got {type(value).__name__}, expected FloatingOptions or a mapping of its fields")


@dataclass
class FloatingStack:
    """What a floating identification adds to the fixed base's setup (``Setup.floating`` of
    :func:`pinid.identification.run.setup`): the training and validation problems, the prepared recordings, the
    convention hints of the raw recordings, the joints whose torque sign looks flipped and the sources' names."""

    problem: IdentificationProblem
    validation: IdentificationProblem | None
    train: list[FloatingSamples]
    validation_samples: list[FloatingSamples]
    hints: list[str]
    flipped: list[str]
    sources: str
    torque_scale: float | None = None  # recorded / the URDF's joint torque (plausibility.torque_scale)
    calibration: object = None  # the Calibration applied to the training and validation recordings
    rows: str = "all"  # the rows used: the options', or "base" for recordings without joint torque


def validate_floating(run: FloatingStack, results: Mapping) -> TorqueMetrics | None:
    """Each result's ``validation`` (RMS per body, the 6 base rows together as ``base`` [N and N·m mixed]) on the
    validation rows, against their prepared wrench and torque; returns the model-class floor (:func:`_floor`),
    None without validation."""
    if not isinstance(run, FloatingStack) or not isinstance(results, Mapping):
        raise SpecError("validate_floating: expected a FloatingStack and the results by method")
    val = run.validation
    if val is None:
        return None
    names, units = val.model.joint_names, joint_units(val.model)
    for r in results.values():
        r.validation = error_metrics(val.tau, val.tau - val.predict(r.base), names, val.joint, units)
        r.validation_filtered = r.validation
    return _floor(val)


def check_floating(run: FloatingStack, ident, model: FloatingRobotModel, rows: str) -> None:
    """The checks of a floating identification's results: the total mass (warned, or refused when every method's
    is absurd), the barely excited base parameters, the whole-body centre of mass (``info["com"]``); then the
    total mass and centre of mass with σ (:func:`pinid.identification.mass.mass_and_com`) and the figures'
    traces with each method's per-axis error (:func:`floating_curves`)."""
    if not isinstance(run, FloatingStack) or not hasattr(ident, "results") or rows not in ROWS:
        raise SpecError("check_floating: expected a FloatingStack, an Identification and the rows used")
    ident.data["flipped_torque_signs"] = run.flipped
    _check_total_mass(ident, run.hints, run.sources, run.problem.base)
    excitation_warning(ident, run.problem.natural_scale, run.sources)
    if rows != "joints":
        posture = np.mean(np.concatenate([s.data.q for s in run.train]), axis=0)
        com_warning(ident, model, run.problem.terms, run.problem.base, posture, run.sources, run.hints)
        mass_and_com(ident, model, run.problem, posture)  # with σ, for the text, the JSON and the report
    ident.curves.update(floating_curves(run, ident, model))  # the floating figures' traces, each axis's error


#: The six base rows of a sample, in the order the problem stacks them (force, then moment, base frame).
BASE_AXES: tuple[str, ...] = ("fx", "fy", "fz", "tx", "ty", "tz")


def _base_rows(problem: IdentificationProblem) -> np.ndarray:
    """Indices of the problem's base rows, 6 per sample in :data:`BASE_AXES`' order (body 0 is the base)."""
    rows = np.flatnonzero(np.asarray(problem.joint) == 0)
    return rows if len(rows) % 6 == 0 else rows[: len(rows) - len(rows) % 6]


def base_axis_errors(
    problem: IdentificationProblem, base: np.ndarray, predicted: np.ndarray | None = None
) -> dict[str, dict[str, float]]:
    """The error of each base row (``fx`` … ``tz``) of base parameters ``base`` on ``problem``: ``{axis: {"rms",
    "rel_rms_percent"}}`` [N or N·m], against the wrench as prepared; {} without base rows.  ``predicted``:
    ``problem.predict(base)`` when already computed (a pass over the regressor's blocks)."""
    rows = _base_rows(problem)
    if not len(rows):
        return {}
    y = np.asarray(problem.tau)[rows].reshape(-1, 6)
    predicted = problem.predict(base) if predicted is None else predicted
    e = y - np.asarray(predicted)[rows].reshape(-1, 6)
    rms, ref = np.sqrt(np.mean(e**2, axis=0)), np.sqrt(np.mean(y**2, axis=0))
    return {
        a: {"rms": float(r), "rel_rms_percent": float(100 * r / f) if f > 0 else float("nan")}
        for a, r, f in zip(BASE_AXES, rms, ref)
    }


def _predict_all(problem: IdentificationProblem, bases: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """``problem.predict`` of every base vector in one pass over the regressor's blocks (each pass rebuilds them)."""
    if not bases:
        return {}
    B = np.column_stack([np.asarray(b, dtype=float) for b in bases.values()])
    if not problem.blocked:
        P = problem.W @ B
    else:
        P = np.empty((problem.rows, B.shape[1]))
        for r, Wk in problem.regressor_rows.blocks():
            P[r : r + len(Wk)] = Wk @ B
    return {m: P[:, k] for k, m in enumerate(bases)}


def _yaw(quat: np.ndarray) -> np.ndarray:
    """Heading [rad] of (N, 4) quaternions ``x, y, z, w`` (the yaw of R = Rz(yaw)·Ry(pitch)·Rx(roll))."""
    x, y, z, w = np.asarray(quat, dtype=float).T
    return np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def joint_chains(model) -> list[list[str]]:
    """The actuated joints of a floating ``model`` grouped in unbranched chains (a leg, an arm, the torso up to
    where the arms part, the neck), each in the model's order: a chain starts at a joint whose parent is the base
    or has several child joints."""
    m = model.ff_model
    ids = {name: m.getJointId(name) for name in model.joint_names}
    children: dict[int, int] = {}
    for j in range(2, m.njoints):
        children[m.parents[j]] = children.get(m.parents[j], 0) + 1
    chains: dict[int, list[str]] = {}
    for name, j in ids.items():
        head = j
        while m.parents[head] > 1 and children.get(m.parents[head], 0) == 1:
            head = m.parents[head]
        chains.setdefault(head, []).append(name)
    return list(chains.values())


def floating_curves(run: FloatingStack, ident, model: FloatingRobotModel) -> dict:
    """What the floating figures draw (:mod:`pinid.report.plot_floating`; not saved): ``"wrench"`` — the base
    wrench measured and predicted by the best method on the first validation recording (else the first training
    one), per axis; ``"chains"`` — the model's joints by chain (:func:`joint_chains`); ``"determined"`` — per base
    parameter, whether the best method's 2σ is within EXCITED_FRACTION of its natural scale;
    ``"contacts"`` — the normal force of each measured wrench on that recording; ``"base"`` — the
    base position and heading of every recording, by role.  Each method's per-axis errors go into its
    ``info["base_axes"]`` (``{"on": "validation" | "training", axis: {"rms", "rel_rms_percent"}}``)."""
    problem, samples, on = (
        (run.validation, run.validation_samples, "validation")
        if run.validation is not None
        else (run.problem, run.train, "training")
    )
    predictions = _predict_all(problem, {m: r.base for m, r in ident.results.items()})
    for m, r in ident.results.items():
        axes = base_axis_errors(problem, r.base, predictions[m])
        if axes:
            r.info["base_axes"] = {"on": on, **axes}
    curves: dict = {}
    rows = _base_rows(problem)
    if len(rows) and ident.results:
        first = np.asarray(problem.sample)[rows][::6] < samples[0].n  # the first recording's samples
        keep = np.repeat(first, 6)
        idx = np.asarray(problem.sample)[rows][::6][first]
        measured = np.asarray(problem.tau)[rows][keep].reshape(-1, 6)
        best = ident.best
        predicted = {best: np.asarray(predictions[best])[rows][keep].reshape(-1, 6)}
        curves["wrench"] = {
            "t": samples[0].data.t[idx],
            "measured": measured,
            "predicted": predicted,
            "source": samples[0].source,
            "kind": on,
        }
    s = samples[0]
    if s.wrenches:
        curves["contacts"] = {
            "t": s.data.t,
            "forces": {w.link: np.asarray(w.values)[:, 2] for w in s.wrenches},
            "source": s.source,
            "kind": on,
        }
    curves["chains"] = joint_chains(model)
    if ident.results:  # the base parameters the data determine (the parameter figure's), by the warning's rule
        std = np.asarray(ident.results[ident.best].std, dtype=float)
        scale = np.asarray(run.problem.natural_scale, dtype=float)
        curves["determined"] = (np.isfinite(std) & (2 * std <= EXCITED_FRACTION * scale)).tolist()
    curves["base"] = [
        {
            "label": f"{role}: {Path(str(r.source)).name}",
            "t": r.data.t,
            "position": r.base_q[:, :3],
            "yaw": _yaw(r.base_q[:, 3:]),
        }
        for role, group in (("training", run.train), ("validation", run.validation_samples))
        for r in group
        if np.any(r.base_q[:, :3])  # an IMU gives no position
    ]
    return curves


def floating_truth(truth, problem) -> np.ndarray:
    """The true base parameters of ``problem`` from a truth dict or its JSON path (``standard_names`` and
    ``standard`` of ``pinid simulate --base floating``).  SpecError naming what is missing."""
    origin = str(truth) if isinstance(truth, (str, os.PathLike)) else "truth"
    d = read_json(truth, "truth") if isinstance(truth, (str, os.PathLike)) else truth
    if not isinstance(d, Mapping) or d.get("base") != "floating" or "standard" not in d or "standard_names" not in d:
        raise SpecError(f"{origin}: not the truth of a floating twin (pinid simulate --base floating)")
    values = dict(zip(d["standard_names"], d["standard"]))
    missing = [n for n in problem.standard_names if n not in values]
    if missing:
        raise SpecError(f"{origin}: no true value of {', '.join(missing[:3])} (another robot or other --terms)")
    return problem.base.from_standard(np.array([float(values[n]) for n in problem.standard_names]))


#: identified total mass / the URDF's: outside this band a warning, outside ``MASS_REFUSED`` (or ≤ 0 for every
#: method) an error: nothing sensible can come out of such a recording (docs/floating-base.md)
MASS_WARNED = (0.5, 2.0)
MASS_REFUSED = (0.2, 5.0)


def recording_hints(rec, model: FloatingRobotModel) -> list[str]:
    """What in a raw floating recording points to a convention error, one phrase each: contact phases that are 0
    (not in contact) on most samples where the measured force exceeds half the robot's weight (phase logic
    inverted), an accelerometer whose mean specific force is far below g (gravity left out), base positions
    beyond 20 m (millimetres), a quaternion whose x is near ±1 on average (w first: an upright robot's w read as
    x); and (issue 47) a loaded contact whose sensor reads zero for a stretch (:func:`~pinid.identification.
    floating_checks.plate_dropouts`), a plate's centre of pressure far from its foot and plates on the wrong
    feet (:func:`~pinid.identification.floating_checks.foot_hints`), a gyro in deg/s and an accelerometer of
    flipped sign (:func:`~pinid.identification.floating_checks.imu_hints`).  Each is also warned about at once
    (one line)."""
    from pinid.identification.floating_checks import foot_hints, imu_hints, plate_dropouts

    weight = sum(float(i.mass) for i in model.ff_model.inertias) * 9.81
    src, raw = rec.source, rec
    hints = [*plate_dropouts(raw, weight), *foot_hints(raw, model, weight), *imu_hints(raw)]
    for line in hints:
        warnings.warn(line, stacklevel=3)
    rec = rec.floating
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


def _check_total_mass(ident, hints: list[str], source: str, base) -> None:
    """Warn when a method's total mass is outside ``MASS_WARNED`` × the URDF's, refuse (DataError) when every
    method's is outside ``MASS_REFUSED`` × or negative, naming the likely cause."""
    c = total_mass_combination(base)  # base.mR on most robots; any combination the rows determine
    if c is None:
        return
    nominal = float(c @ np.asarray(ident.base["nominal"], dtype=float))
    masses = {m: float(c @ np.asarray(r.base, dtype=float)) for m, r in ident.results.items()}
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


def _floor(problem: IdentificationProblem) -> TorqueMetrics | None:
    """The model-class floor (:mod:`pinid.identification.floor`): OLS fitted on the validation rows themselves,
    its error over them per body (``base``: the 6 wrench rows) [N·m, N]; None when they do not determine the
    parameters alone."""
    try:
        base = make_estimator("ols").fit(problem).base_
    except (np.linalg.LinAlgError, DataError, ValueError):
        return None
    names = problem.model.joint_names
    return error_metrics(
        problem.tau, problem.tau - problem.predict(base), names, problem.joint, joint_units(problem.model)
    )
