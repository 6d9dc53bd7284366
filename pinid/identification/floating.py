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
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from pinid.data.contacts import FloatingSamples
from pinid.errors import DataError, SpecError
from pinid.estimators import make_estimator
from pinid.identification.floating_checks import (
    com_warning,
    mass_and_com,
    total_mass_combination,
    excitation_warning,
)
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
    the rows their unknown wrench enters are left out while they are in contact)."""

    rows: str = "all"
    base_weight: float = 1.0
    swing_rows: bool = False

    def __post_init__(self) -> None:
        if self.rows not in ROWS:
            raise SpecError(f"rows: got {self.rows!r}, expected one of {', '.join(ROWS)}")
        if isinstance(self.base_weight, bool) or not isinstance(self.base_weight, (int, float)):
            raise SpecError(f"base_weight: got {type(self.base_weight).__name__}, expected a number")
        if not isinstance(self.swing_rows, bool):
            raise SpecError(f"swing_rows: got {type(self.swing_rows).__name__}, expected True or False")


#: The command-line option of a study argument whose name is not the option's (the rest: ``--name-with-dashes``).
_OPTIONS = {"segmental": "--first-data", "terms": "--terms auto"}


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
        unknown = [k for k in value if k not in ("rows", "base_weight", "swing_rows")]
        if unknown:
            raise SpecError(
                f"floating: unknown option(s) {', '.join(map(str, unknown))} (rows, base_weight, swing_rows)"
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
    is absurd), the barely excited base parameters, the whole-body centre of mass (``info["com"]``)."""
    if not isinstance(run, FloatingStack) or not hasattr(ident, "results") or rows not in ROWS:
        raise SpecError("check_floating: expected a FloatingStack, an Identification and the rows used")
    ident.data["flipped_torque_signs"] = run.flipped
    _check_total_mass(ident, run.hints, run.sources, run.problem.base)
    excitation_warning(ident, run.problem.natural_scale, run.sources)
    if rows != "joints":
        posture = np.mean(np.concatenate([s.data.q for s in run.train]), axis=0)
        com_warning(ident, model, run.problem.terms, run.problem.base, posture, run.sources)
        mass_and_com(ident, model, run.problem, posture)  # with σ, for the text, the JSON and the report


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
    x).  Each is also warned about at once (one line)."""
    weight = sum(float(i.mass) for i in model.ff_model.inertias) * 9.81
    src, hints = rec.source, []
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
