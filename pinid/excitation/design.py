"""Excitation design: Fourier trajectories that make the base regressor well conditioned within limits.

The trajectory of every joint is a finite Fourier series (seed 001 Eq. (19), :class:`FourierTrajectory`)::

    q_j(t) = q0_j + Σ_{k=1..N} a_jk sin(k ω t) + b_jk cos(k ω t)

and the design minimises a criterion of the **base regressor** ``W_b`` (the base columns of
:func:`pinid.model.regressor`, joint terms — Coulomb and viscous friction by default — included, unscaled)
stacked over ``samples`` equally spaced instants of one period:

* ``cond`` (default): the condition number ``σ_max/σ_min`` of ``W_b`` (seed 001 Eq. (20), ``np.linalg.cond``);
* ``logdet``: the D-optimal criterion, ``−log det(W_bᵀ W_b)`` (maximises the information).

subject to the limits of every joint — position, velocity, acceleration, optionally torque — at every
instant of the period, not only at the samples.

Limits
------
An :class:`ExcitationSpec` holds them.  Position and velocity limits come from the URDF; a spec file
(TOML or JSON, see ``excitation/exo_leg_table2.toml``) adds what a URDF cannot hold — acceleration
limits, margins, the offsets q0, the number of harmonics, the base frequency — and may tighten (never
widen) the URDF's limits.  Without a spec file: URDF limits, ``DEFAULT_ACCELERATION`` for the
acceleration, ``DEFAULT_VELOCITY`` where the URDF gives no velocity, ``q0 ± DEFAULT_HALF_RANGE`` where
it gives no position limits, offsets at the centres of the ranges.

Start at rest
-------------
With ``rest_start`` (the default) dq(0) = ddq(0) = 0 — and so at the end of every period — by
construction: the first harmonic is eliminated, ``a_1 = −Σ_{k≥2} k a_k`` and ``b_1 = −Σ_{k≥2} k² b_k``,
so every optimiser gets it for free and it holds to rounding error.

Optimisers
----------
``slsqp`` (default) is a gradient-based multistart made for this problem.  With the offsets fixed (or
free), q, dq and ddq are *linear* in the design variables, so the kinematic limits on a grid of the
period (twice as fine as the samples) are linear inequality constraints, handed to scipy's SLSQP exactly.
The gradient of log cond(W_b) comes from the singular vectors of W_b and the derivatives of each
sample's regressor row with respect to that sample's state (:meth:`DesignProblem.objective_and_gradient`).
The landscape has many local minima, so the search has two phases (:class:`MultistartOptions`): many
short local searches on a cheaper problem (50 samples per period), from the best of several random
feasible points each, then the best few results polished on the full problem.

The metaheuristics of :mod:`pinid.optimizers` (``pso``, ``woa``, ``ewoa``, ``de``) search the same
variables inside a box; the limits hold **by construction**: each candidate's coefficients are scaled,
per joint, by the largest factor ≤ 1 that brings its position, velocity and acceleration inside the
limits on the grid (the offset stays).  The reported best is therefore feasible.  Torque limits, which
scaling cannot guarantee, are a penalty for the metaheuristics and nonlinear constraints for SLSQP.

Whatever the optimiser, the final trajectory is checked on a dense grid (``DENSE_SAMPLES`` per period,
extremes refined by Newton steps on the analytic derivatives) and, if it overshoots a limit between the
design samples, scaled back inside (a change of the order of 1e-4 of the amplitudes); the condition
number reported is then recomputed with :func:`condition_number` on the ``samples`` grid.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinid.model.base import BaseParameters, base_parameters
from pinid.blas import single_threaded_blas
from pinid.checks import count, number, option_numbers
from pinid.errors import SpecError
from pinid.io import display_path, parse_spec_text, read_bounded_file
from pinid.memory import check_fits
from pinid.resources import EXCITATION_DIR as BUNDLED_EXCITATION_DIR
from pinid.model.robot import RobotModel, as_robot
from pinid.model.regressor import JointTerms, regressor, standard_parameters
from pinid.model.terms import count as _term_count
from pinid.excitation.trajectory import FourierTrajectory
from pinid.io import write_json
from pinid.model.bundled import BUNDLED_URDF_DIR
from pinid.optimizers import OPTIMIZERS, get_optimizer
from pinid.progress import progress as progress_bar
from pinid.io import as_path

#: Acceleration limit [rad/s² or m/s²] when neither the spec nor the URDF gives one.
DEFAULT_ACCELERATION = 5.0
#: Velocity limit [rad/s or m/s] when the URDF gives none.
DEFAULT_VELOCITY = 2.0
#: Half position range [rad or m] around q0 when the URDF gives no position limits.
DEFAULT_HALF_RANGE = math.pi
DEFAULT_HARMONICS = 4
#: Seed 001's base frequency ωf = 0.2π rad/s (period 10 s).
DEFAULT_BASE_FREQUENCY = 0.2 * math.pi
#: Samples per period of the regressor whose condition number is minimised.
DEFAULT_SAMPLES = 200
#: Points per period of the grid on which the final extremes are measured.
DENSE_SAMPLES = 4000
#: robots with up to this many joints get the full default multistart (128 starts, 4 polished)
SMALL_ROBOT = 4
#: Smallest motion [rad or m] a joint's limits must allow at the base frequency.
MIN_AMPLITUDE = 1e-3
#: Criteria: name -> description.
CRITERIA = {
    "cond": "condition number of the base regressor (seed 001 Eq. (20))",
    "logdet": "D-optimal: −log det(W_bᵀ W_b)",
}
#: Spec files used by default for bundled robots (in the repository's ``excitation/`` folder).
DEFAULT_SPECS = {"exo_leg": "exo_leg_table2.toml"}
#: The repository's ``excitation/`` folder.
EXCITATION_DIR = BUNDLED_EXCITATION_DIR

_REST_TOL = 1e-10  # |dq| below this at a sample is exact rest (sign(dq) = 0 in the Coulomb column)
_SPEC_KEYS = {
    "description",
    "urdf",
    "harmonics",
    "base_frequency",
    "samples",
    "rest_start",
    "optimize_offsets",
    "margin",
    "criterion",
    "terms",
    "q0",
    "joints",
    "torque_limits",
}
_JOINT_KEYS = {"q_min", "q_max", "dq_max", "ddq_max", "tau_max", "q0"}


# ====================================================================================== specification
@dataclass
class ExcitationSpec:
    """Limits and settings of an excitation design; arrays are per active joint, in model order.

    ``q_min``, ``q_max`` [rad], ``dq_max`` [rad/s], ``ddq_max`` [rad/s²], ``tau_max`` [N·m] (inf: none),
    ``q0`` [rad] the offsets (fixed unless ``optimize_offsets``).  ``margin`` is a fraction of every limit
    kept in reserve: the position range shrinks by ``margin·(q_max − q_min)`` at each end, the velocity
    and acceleration limits by the factor ``1 − margin``.
    """

    joints: list[str]
    q_min: np.ndarray
    q_max: np.ndarray
    dq_max: np.ndarray
    ddq_max: np.ndarray
    q0: np.ndarray
    tau_max: np.ndarray | None = None
    harmonics: int = DEFAULT_HARMONICS
    base_frequency: float = DEFAULT_BASE_FREQUENCY
    samples: int = DEFAULT_SAMPLES
    rest_start: bool = True
    optimize_offsets: bool = False
    margin: float = 0.0
    criterion: str = "cond"
    terms: JointTerms = field(default_factory=JointTerms)
    source: str = "defaults"

    def __post_init__(self) -> None:
        nv = len(self.joints)
        for name in ("q_min", "q_max", "dq_max", "ddq_max", "q0", "tau_max"):
            value = getattr(self, name)
            if value is None:
                value = np.full(nv, np.inf)
            value = np.asarray(value, dtype=float).reshape(-1)
            if value.shape != (nv,):
                raise SpecError(f"{self.source}: {name} has {value.size} values, expected {nv} (joints {self.joints})")
            setattr(self, name, value)

    # ------------------------------------------------------------------ derived limits
    @property
    def period(self) -> float:
        """Period 2π/ω [s]."""
        return 2 * math.pi / self.base_frequency

    @property
    def lower(self) -> np.ndarray:
        """Lower position limits after the margin [rad]."""
        return self.q_min + self.margin * (self.q_max - self.q_min)

    @property
    def upper(self) -> np.ndarray:
        """Upper position limits after the margin [rad]."""
        return self.q_max - self.margin * (self.q_max - self.q_min)

    @property
    def velocity(self) -> np.ndarray:
        """Velocity limits after the margin [rad/s]."""
        return self.dq_max * (1 - self.margin)

    @property
    def acceleration(self) -> np.ndarray:
        """Acceleration limits after the margin [rad/s²]."""
        return self.ddq_max * (1 - self.margin)

    @property
    def torque(self) -> np.ndarray:
        """Torque limits after the margin [N·m] (inf: none)."""
        return self.tau_max * (1 - self.margin)

    @property
    def has_torque_limits(self) -> bool:
        """True when any joint has a torque limit (then the design computes torques with the nominal URDF)."""
        return bool(np.any(np.isfinite(self.tau_max)))

    def replace(self, **changes) -> "ExcitationSpec":
        """A copy with some settings changed (``spec.replace(harmonics=6)``)."""
        return replace(self, **changes)

    def limits_dict(self) -> dict:
        """Per joint ``{q_min, q_max, dq_max, ddq_max, tau_max}`` as given (before the margin); None = no limit."""

        def num(x):
            return float(x) if np.isfinite(x) else None

        return {
            j: {
                "q_min": num(self.q_min[i]),
                "q_max": num(self.q_max[i]),
                "dq_max": num(self.dq_max[i]),
                "ddq_max": num(self.ddq_max[i]),
                "tau_max": num(self.tau_max[i]),
            }
            for i, j in enumerate(self.joints)
        }

    def to_dict(self) -> dict:
        """Plain-dict form of the settings and limits."""
        return {
            "source": self.source,
            "harmonics": int(self.harmonics),
            "base_frequency": float(self.base_frequency),
            "samples": int(self.samples),
            "rest_start": bool(self.rest_start),
            "optimize_offsets": bool(self.optimize_offsets),
            "margin": float(self.margin),
            "criterion": self.criterion,
            "terms": self.terms.names,
            "q0": self.q0.tolist(),
            "limits": self.limits_dict(),
        }

    # ------------------------------------------------------------------ checks
    def validate(self, model: RobotModel | None = None, base: BaseParameters | None = None) -> None:
        """Raise SpecError, with a one-line message naming the joint and the limit, if no useful
        trajectory can meet these settings."""
        src = self.source
        if int(self.harmonics) != self.harmonics or self.harmonics < 1:
            raise SpecError(f"{src}: harmonics {self.harmonics!r}, expected an integer >= 1")
        if self.rest_start and self.harmonics < 2:
            raise SpecError(
                f"{src}: rest_start needs at least 2 harmonics (it uses up the first), got {self.harmonics}"
            )
        if not (np.isfinite(self.base_frequency) and self.base_frequency > 0):
            raise SpecError(f"{src}: base_frequency {self.base_frequency!r}, expected > 0 [rad/s]")
        if int(self.samples) != self.samples or self.samples <= 2 * self.harmonics:
            raise SpecError(
                f"{src}: samples {self.samples!r}, expected an integer > 2·harmonics = {2 * self.harmonics} "
                "(the samples must resolve the highest harmonic)"
            )
        if not (0 <= self.margin < 0.5):
            raise SpecError(f"{src}: margin {self.margin!r}, expected a fraction in [0, 0.5)")
        if self.criterion not in CRITERIA:
            raise SpecError(f"{src}: criterion {self.criterion!r}, expected one of {', '.join(CRITERIA)}")
        w = self.base_frequency
        for i, j in enumerate(self.joints):
            lo, hi, q0 = self.q_min[i], self.q_max[i], self.q0[i]
            if not (np.isfinite(lo) and np.isfinite(hi)):
                raise SpecError(f"{src}: joint '{j}': position range [{lo:g}, {hi:g}] is not finite")
            if not lo < hi:
                raise SpecError(
                    f"{src}: joint '{j}': position range [{lo:g}, {hi:g}] has no width, expected q_min < q_max"
                )
            for name, value, unit in (("dq_max", self.dq_max[i], "rad/s"), ("ddq_max", self.ddq_max[i], "rad/s²")):
                if not (np.isfinite(value) and value > 0):
                    raise SpecError(f"{src}: joint '{j}': {name} {value:g}, expected a finite limit > 0 [{unit}]")
            if not np.isnan(self.tau_max[i]) and self.tau_max[i] <= 0:
                raise SpecError(f"{src}: joint '{j}': tau_max {self.tau_max[i]:g}, expected > 0 [N·m] (or no limit)")
            if not np.isfinite(q0) or not (self.lower[i] < q0 < self.upper[i]):
                extra = f" (after the margin {self.margin:g})" if self.margin else ""
                raise SpecError(
                    f"{src}: joint '{j}': offset q0 = {q0:g} is outside its range "
                    f"[{self.lower[i]:.6g}, {self.upper[i]:.6g}]{extra}; expected strictly inside"
                )
            room = {
                "position": min(q0 - self.lower[i], self.upper[i] - q0),
                "dq_max": self.velocity[i] / w,
                "ddq_max": self.acceleration[i] / w**2,
            }
            which = min(room, key=room.get)
            if room[which] < MIN_AMPLITUDE:
                if which == "position":
                    why = f"offset q0 = {q0:g} is only {room[which]:.3g} rad from a position limit"
                else:
                    value = self.velocity[i] if which == "dq_max" else self.acceleration[i]
                    why = (
                        f"{which} {value:g} allows at most {room[which]:.3g} rad of motion at base frequency "
                        f"{w:g} rad/s"
                    )
                raise SpecError(
                    f"{src}: joint '{j}': {why}; expected room for at least {MIN_AMPLITUDE:g} rad "
                    "(widen the limit or lower base_frequency)"
                )
        if model is not None:
            if model.joint_names != list(self.joints):
                raise SpecError(f"{src}: joints {self.joints} do not match the model's {model.joint_names}")
            nb = (base or base_parameters(model, self.terms)).count
            if self.samples * model.nv < nb:
                raise SpecError(
                    f"{src}: samples {self.samples} × {model.nv} joints = {self.samples * model.nv} rows "
                    f"< {nb} base parameters; expected more samples"
                )


def default_spec(model: RobotModel, **settings) -> ExcitationSpec:
    """Limits from the URDF plus pinid's defaults (see the module documentation); ``settings`` override
    any field of :class:`ExcitationSpec` (``harmonics=6``, ``rest_start=False``...)."""
    model = as_robot(model)
    lo, hi = model.lower.copy(), model.upper.copy()
    both = np.isfinite(lo) & np.isfinite(hi)
    q0 = np.zeros(model.nv)
    q0[both] = 0.5 * (lo[both] + hi[both])
    only_lo, only_hi = np.isfinite(lo) & ~np.isfinite(hi), ~np.isfinite(lo) & np.isfinite(hi)
    q0 = np.where(only_lo, lo + DEFAULT_HALF_RANGE, q0)
    q0 = np.where(only_hi, hi - DEFAULT_HALF_RANGE, q0)
    lo = np.where(np.isfinite(lo), lo, q0 - DEFAULT_HALF_RANGE)
    hi = np.where(np.isfinite(hi), hi, q0 + DEFAULT_HALF_RANGE)
    vel = np.where(np.isfinite(model.velocity_limit), model.velocity_limit, DEFAULT_VELOCITY)
    fields_ = dict(
        joints=model.joint_names,
        q_min=lo,
        q_max=hi,
        dq_max=vel,
        ddq_max=np.full(model.nv, DEFAULT_ACCELERATION),
        q0=q0,
        tau_max=np.full(model.nv, np.inf),
        source=f"{model.urdf_path.name if model.urdf_path else model.name} (URDF limits, pinid defaults)",
    )
    fields_.update(settings)
    return ExcitationSpec(**fields_)


def bundled_spec_path(model: RobotModel) -> Path | None:
    """The spec file pinid uses by default for a bundled robot (``exo_leg`` → ``excitation/exo_leg_table2.toml``)."""
    model = as_robot(model)
    if model.urdf_path is None:
        return None
    path = Path(model.urdf_path)
    name = DEFAULT_SPECS.get(path.stem)
    if name is None:
        return None
    try:  # the bundled file itself (any path to it) or an unchanged copy; an edited copy gets its own limits
        bundled = BUNDLED_URDF_DIR / f"{path.stem}.urdf"
        if not (bundled.exists() and (os.path.samefile(bundled, path) or bundled.read_bytes() == path.read_bytes())):
            return None
    except OSError:
        return None
    spec = EXCITATION_DIR / name
    return spec if spec.is_file() else None


def load_spec(path: str | os.PathLike, model: RobotModel) -> ExcitationSpec:
    """Read a spec file (``.toml`` or ``.json``) for ``model``: URDF limits, overridden (tightened) by the file."""
    path = as_path(path)
    p = Path(path)
    text = read_bounded_file(p, "excitation spec (.toml or .json)")
    kind = "JSON" if p.suffix.lower() == ".json" else "TOML"
    data = parse_spec_text(text, str(p), "excitation spec", kind=kind)
    if not isinstance(data, dict):
        raise SpecError(f"{p}: expected a table of settings at the top level")
    return spec_from_dict(data, model, source=display_path(p))


def spec_from_dict(data: dict, model: RobotModel, *, source: str = "<spec>") -> ExcitationSpec:
    """Build a spec from the plain-dict form of a spec file (see ``excitation/exo_leg_table2.toml``)."""
    if not isinstance(data, dict):
        raise SpecError(f"{source}: data: got {type(data).__name__}, expected a table of settings")
    unknown = sorted(set(data) - _SPEC_KEYS)
    if unknown:
        raise SpecError(f"{source}: unknown setting(s) {', '.join(unknown)} (known: {', '.join(sorted(_SPEC_KEYS))})")
    spec = default_spec(model)
    changes: dict = {"source": source}

    def number(value, what, integer=False):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise SpecError(f"{source}: {what} = {value!r}, expected a number")
        if integer and int(value) != value:
            raise SpecError(f"{source}: {what} = {value!r}, expected an integer")
        return int(value) if integer else float(value)

    def flag(value, what):
        if not isinstance(value, bool):
            raise SpecError(f"{source}: {what} = {value!r}, expected true or false")
        return value

    if "harmonics" in data:
        changes["harmonics"] = number(data["harmonics"], "harmonics", integer=True)
    if "samples" in data:
        changes["samples"] = number(data["samples"], "samples", integer=True)
    if "base_frequency" in data:
        changes["base_frequency"] = number(data["base_frequency"], "base_frequency")
        if not (np.isfinite(changes["base_frequency"]) and changes["base_frequency"] > 0):  # the period divides by it
            raise SpecError(f"{source}: base_frequency = {data['base_frequency']!r}, expected a number > 0 [rad/s]")
    if "margin" in data:
        changes["margin"] = number(data["margin"], "margin")
    for key in ("rest_start", "optimize_offsets"):
        if key in data:
            changes[key] = flag(data[key], key)
    if "criterion" in data:
        changes["criterion"] = str(data["criterion"])
    if "terms" in data:
        terms = data["terms"]
        try:
            changes["terms"] = JointTerms.from_names(terms if isinstance(terms, (str, list)) else str(terms))
        except ValueError as exc:
            raise SpecError(f"{source}: terms: {exc}") from None
    arrays = {k: getattr(spec, k).copy() for k in ("q_min", "q_max", "dq_max", "ddq_max", "tau_max", "q0")}
    urdf_limits = {"q_min": model.lower, "q_max": model.upper, "dq_max": model.velocity_limit}
    if data.get("torque_limits") is not None:
        if flag(data["torque_limits"], "torque_limits"):
            arrays["tau_max"] = model.effort_limit.copy()
    q0 = data.get("q0", {})
    if not isinstance(q0, dict):
        raise SpecError(f"{source}: q0 must be a table joint = value [rad], e.g. q0 = {{hip = 0.61}}")
    joints = data.get("joints", {})
    if not isinstance(joints, dict):
        raise SpecError(f"{source}: joints must be a table of tables, e.g. [joints.hip] q_min = -0.1")
    q0_given = set()
    for jname, value in q0.items():
        i = _joint(model, jname, source)
        arrays["q0"][i] = number(value, f"q0.{jname}")
        q0_given.add(i)
    for jname, table in joints.items():
        i = _joint(model, jname, source)
        if not isinstance(table, dict):
            raise SpecError(f"{source}: joints.{jname} must be a table of limits ({', '.join(sorted(_JOINT_KEYS))})")
        bad = sorted(set(table) - _JOINT_KEYS)
        if bad:
            raise SpecError(
                f"{source}: joints.{jname}: unknown key(s) {', '.join(bad)} (known: {', '.join(sorted(_JOINT_KEYS))})"
            )
        for key, value in table.items():
            value = number(value, f"joints.{jname}.{key}")
            if key in urdf_limits:  # a spec may tighten the URDF's limits, never widen them
                urdf = urdf_limits[key][i]
                wider = value < urdf - 1e-9 if key == "q_min" else value > urdf + 1e-9
                if np.isfinite(urdf) and wider:
                    raise SpecError(
                        f"{source}: joints.{jname}.{key} = {value:g} is outside the URDF's limit {urdf:g}; "
                        "a spec may tighten the URDF's limits, not widen them"
                    )
            if key == "q0":
                q0_given.add(i)
            arrays[key][i] = value
    # offsets not given: the centre of the (possibly new) range
    for i in range(model.nv):
        if i not in q0_given:
            arrays["q0"][i] = 0.5 * (arrays["q_min"][i] + arrays["q_max"][i])
    changes.update(arrays)
    return spec.replace(**changes)


def _joint(model: RobotModel, name: str, source: str) -> int:
    if name not in model.joint_names:
        raise SpecError(
            f"{source}: joint '{name}' is not an active joint of {model.name} "
            f"(active joints: {', '.join(model.joint_names)})"
        )
    return model.joint_names.index(name)


def spec_for(model: RobotModel, path: str | os.PathLike | None = None, **settings) -> ExcitationSpec:
    """The spec to use: ``path`` if given, else the bundled one for ``exo_leg``, else :func:`default_spec`;
    ``settings`` (not None) override its fields."""
    model = as_robot(model)
    path = path if path is not None else bundled_spec_path(model)
    spec = load_spec(path, model) if path is not None else default_spec(model)
    settings = {k: v for k, v in settings.items() if v is not None}
    return spec.replace(**settings) if settings else spec


# ====================================================================================== evaluation
def sample_times(period: float, samples: int) -> np.ndarray:
    """``samples`` equally spaced instants of one period, starting at 0 [s]."""
    samples = count(samples, "samples", low=1)
    period = number(period, "period", low=0, low_open=True)
    return np.arange(samples) * (period / samples)


def _clean_rest(dq: np.ndarray) -> np.ndarray:
    """Velocities that are zero up to rounding are zero (so that sign(dq) = 0 in the Coulomb column)."""
    return np.where(np.abs(dq) < _REST_TOL, 0.0, dq)


def base_regressor(
    model: RobotModel,
    trajectory: FourierTrajectory,
    terms: JointTerms = JointTerms(),
    samples: int = DEFAULT_SAMPLES,
    base: BaseParameters | None = None,
) -> np.ndarray:
    """The base regressor ``(samples·nv, nb)`` of a trajectory over one period (unscaled)."""
    _check_joints(model, trajectory)
    base = base or base_parameters(model, terms)
    q, dq, ddq = trajectory.evaluate(sample_times(trajectory.period, samples))
    return base.columns(regressor(model, q, _clean_rest(dq), ddq, terms))


def condition_number(
    model: RobotModel,
    trajectory: FourierTrajectory,
    terms: JointTerms = JointTerms(),
    samples: int = DEFAULT_SAMPLES,
    base: BaseParameters | None = None,
) -> float:
    """Condition number of the base regressor (friction columns included, unscaled) over one period,
    ``samples`` equally spaced instants from t = 0 — the figure seed 001 minimises (its Eq. (20))."""
    return float(np.linalg.cond(base_regressor(model, trajectory, terms, samples, base)))


def log_det_information(
    model: RobotModel,
    trajectory: FourierTrajectory,
    terms: JointTerms = JointTerms(),
    samples: int = DEFAULT_SAMPLES,
    base: BaseParameters | None = None,
) -> float:
    """``log det(W_bᵀ W_b)`` of the base regressor (the D-optimal criterion maximises it)."""
    s = np.linalg.svd(base_regressor(model, trajectory, terms, samples, base), compute_uv=False)
    return float(2 * np.sum(np.log(s))) if s[-1] > 0 else -np.inf


def _check_joints(model: RobotModel, trajectory: FourierTrajectory) -> None:
    as_robot(model)
    if not isinstance(trajectory, FourierTrajectory):
        raise SpecError(f"trajectory: got {type(trajectory).__name__}, expected a FourierTrajectory")
    if list(trajectory.joints) != model.joint_names:
        raise SpecError(
            f"trajectory joints {list(trajectory.joints)} do not match the model's active joints {model.joint_names}"
        )


def _refine_extreme(trajectory: FourierTrajectory, t: np.ndarray, order: int, j: int, spacing: float) -> np.ndarray:
    """Newton steps on the derivative of order ``order + 1`` to locate extremes of derivative ``order`` of joint j,
    each step at most the grid ``spacing`` (so that it stays with the extreme the grid found)."""
    for _ in range(8):
        d1 = trajectory.derivative(t, order + 1)[:, j]
        d2 = trajectory.derivative(t, order + 2)[:, j]
        step = np.where(np.abs(d2) > 1e-300, d1 / np.where(d2 == 0, 1, d2), 0.0)
        t = t - np.clip(step, -spacing, spacing)
    return trajectory.derivative(t, order)[:, j]


def trajectory_extremes(trajectory: FourierTrajectory, points: int = DENSE_SAMPLES) -> dict:
    """Per joint ``{q_min, q_max, dq_abs_max, ddq_abs_max}`` over one period [rad, rad/s, rad/s²].

    Measured on a grid of ``points`` per period, each extreme then refined by Newton steps on the analytic
    derivatives (so they are exact to rounding, not to the grid)."""
    if not isinstance(trajectory, FourierTrajectory):
        raise SpecError(f"trajectory: got {type(trajectory).__name__}, expected a FourierTrajectory")
    t = sample_times(trajectory.period, points)
    out = {}
    values = [trajectory.derivative(t, k) for k in range(3)]
    for j, name in enumerate(trajectory.joints):
        q, dq, ddq = (v[:, j] for v in values)
        cand_t = np.array([t[np.argmin(q)], t[np.argmax(q)], t[np.argmax(np.abs(dq))], t[np.argmax(np.abs(ddq))]])
        h = trajectory.period / points
        qr = _refine_extreme(trajectory, cand_t[:2], 0, j, h)
        dqr = _refine_extreme(trajectory, cand_t[2:3], 1, j, h)
        ddqr = _refine_extreme(trajectory, cand_t[3:4], 2, j, h)
        out[name] = {
            "q_min": float(min(q.min(), qr[0])),
            "q_max": float(max(q.max(), qr[1])),
            "dq_abs_max": float(max(np.abs(dq).max(), abs(dqr[0]))),
            "ddq_abs_max": float(max(np.abs(ddq).max(), abs(ddqr[0]))),
        }
    return out


def torque_extremes(
    model: RobotModel, trajectory: FourierTrajectory, terms: JointTerms = JointTerms(), points: int = 1000
) -> np.ndarray:
    """Largest |torque| [N·m] per joint over one period, with the nominal URDF parameters (``points`` samples)."""
    model = as_robot(model)
    q, dq, ddq = trajectory.evaluate(sample_times(trajectory.period, points))
    tau = (regressor(model, q, _clean_rest(dq), ddq, terms) @ standard_parameters(model, terms)).reshape(points, -1)
    return np.abs(tau).max(axis=0)


def limit_usage(
    extremes: dict, spec: ExcitationSpec, tau_abs_max: np.ndarray | None = None, q0: np.ndarray | None = None
) -> dict:
    """How much of each limit a trajectory uses, per joint, as fractions (1.0 = at the limit).

    ``q_low`` / ``q_high``: how far towards each position limit the motion goes from q0 (1 = reaches it);
    ``q_range``: the share of the range covered; ``dq``, ``ddq``, ``tau``: peak over limit.  Limits here are
    the spec's, before the margin; ``q0``: the trajectory's offsets (default: the spec's)."""
    if not isinstance(extremes, dict):
        raise SpecError(f"extremes: got {type(extremes).__name__}, expected the extremes dict of trajectory_extremes")
    out = {}
    q0s = spec.q0 if q0 is None else np.asarray(q0, dtype=float)
    for i, j in enumerate(spec.joints):
        e = extremes[j]
        q0, lo, hi = q0s[i], spec.q_min[i], spec.q_max[i]
        u = {
            "q_low": (q0 - e["q_min"]) / (q0 - lo),
            "q_high": (e["q_max"] - q0) / (hi - q0),
            "q_range": (e["q_max"] - e["q_min"]) / (hi - lo),
            "dq": e["dq_abs_max"] / spec.dq_max[i],
            "ddq": e["ddq_abs_max"] / spec.ddq_max[i],
        }
        if tau_abs_max is not None and np.isfinite(spec.tau_max[i]):
            u["tau"] = float(tau_abs_max[i] / spec.tau_max[i])
        out[j] = {k: float(v) for k, v in u.items()}
    return out


def is_feasible(extremes: dict, spec: ExcitationSpec, tau_abs_max: np.ndarray | None = None, tol: float = 1e-9) -> bool:
    """Whether the extremes are inside the spec's limits (after the margin), to ``tol``."""
    if not isinstance(extremes, dict):
        raise SpecError(f"extremes: got {type(extremes).__name__}, expected the extremes dict of trajectory_extremes")
    for i, j in enumerate(spec.joints):
        e = extremes[j]
        if (
            e["q_min"] < spec.lower[i] - tol
            or e["q_max"] > spec.upper[i] + tol
            or e["dq_abs_max"] > spec.velocity[i] + tol
            or e["ddq_abs_max"] > spec.acceleration[i] + tol
        ):
            return False
        if tau_abs_max is not None and tau_abs_max[i] > spec.torque[i] * (1 + 1e-6):
            return False
    return True


def limit_violations(extremes: dict, spec: ExcitationSpec, tol: float = 1e-9) -> list[str]:
    """One readable line per limit the extremes exceed (after the margin), e.g.
    ``"hip: q_min -0.08742 < -0.087 by 0.00042 rad"``; empty when inside."""
    if not isinstance(extremes, dict):
        raise SpecError(f"extremes: got {type(extremes).__name__}, expected the extremes dict of trajectory_extremes")
    out = []
    for i, j in enumerate(spec.joints):
        e = extremes[j]
        checks = [
            ("q_min", e["q_min"], spec.lower[i], -1, "rad"),
            ("q_max", e["q_max"], spec.upper[i], 1, "rad"),
            ("|dq|", e["dq_abs_max"], spec.velocity[i], 1, "rad/s"),
            ("|ddq|", e["ddq_abs_max"], spec.acceleration[i], 1, "rad/s²"),
        ]
        if "tau_abs_max" in e and np.isfinite(spec.torque[i]):
            checks.append(("|tau|", e["tau_abs_max"], spec.torque[i], 1, "N·m"))
        for name, value, limit, side, unit in checks:
            excess = (value - limit) * side
            if excess > tol:
                rel = "<" if side < 0 else ">"
                out.append(f"{j}: {name} {value:.6g} {rel} {limit:.6g} by {excess:.2g} {unit}")
    return out


# ====================================================================================== the design problem
class DesignProblem:
    """The design variables, their map to Fourier coefficients, limits as linear constraints, and the
    criterion evaluated for a whole batch of candidates.

    Variables ``x``, per joint j in model order: the free coefficients ``z_j`` — ``[a_1..a_N, b_1..b_N]``,
    or without a_1 and b_1 when starting at rest — then the offsets q0 (one per joint) when
    ``optimize_offsets``.  Coefficients are ``c_j = T z_j`` (T eliminates a_1, b_1 for rest start).
    """

    def __init__(
        self,
        model: RobotModel,
        spec: ExcitationSpec,
        *,
        check_samples: int | None = None,
        base: BaseParameters | None = None,
    ) -> None:
        self.model, self.spec = model, spec
        self.base = base or base_parameters(model, spec.terms)
        spec.validate(model, self.base)
        self.nv, self.N, self.w = model.nv, int(spec.harmonics), float(spec.base_frequency)
        N = self.N
        k = np.arange(1, N + 1)
        # T: (2N, m) from free variables to [a_1..a_N, b_1..b_N]
        if spec.rest_start:
            m = 2 * (N - 1)
            T = np.zeros((2 * N, m))
            T[1:N, : N - 1] = np.eye(N - 1)
            T[N + 1 :, N - 1 :] = np.eye(N - 1)
            T[0, : N - 1] = -k[1:]  # a_1 = −Σ k a_k   (dq(0) = 0)
            T[N, N - 1 :] = -(k[1:] ** 2)  # b_1 = −Σ k² b_k  (ddq(0) = 0)
            self.harmonic_of = np.concatenate([k[1:], k[1:]])
        else:
            m = 2 * N
            T = np.eye(2 * N)
            self.harmonic_of = np.concatenate([k, k])
        self.T, self.m = T, m
        self.d = self.nv * m + (self.nv if spec.optimize_offsets else 0)
        # The regressor of every sample and its derivatives along the d variables: about 17 kB per
        # sample for exo_leg (8 bytes · nv · p · (2d + 20); measured, docs/benchmarks.md "Memory").
        per_sample = 8.0 * self.nv * len(self.base.standard_names) * (2 * self.d + 20)
        check_fits(
            per_sample * spec.samples,
            f"samples={spec.samples} (--samples, or samples in the spec)",
            per_item=per_sample,
        )
        self.times = sample_times(spec.period, spec.samples)
        self.check_times = sample_times(spec.period, check_samples or max(2 * spec.samples, 40 * N))
        self._basis_design, self._basis_check = self._basis_at(self.times), self._basis_at(self.check_times)
        self.theta = standard_parameters(model, spec.terms) if spec.has_torque_limits else None
        self.nfev = 0  # criterion values computed (a value with its gradient counts once)
        self.regressor_samples = 0  # samples whose regressor was computed: the cost of the design

    # ------------------------------------------------------------------ variables
    def _basis_at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Matrices (n, m) from free variables z_j to q − q0, dq, ddq at times t."""
        kw = np.arange(1, self.N + 1) * self.w
        s, c = np.sin(np.outer(t, kw)), np.cos(np.outer(t, kw))
        Bq = np.hstack([s, c]) @ self.T
        Bdq = np.hstack([c * kw, -s * kw]) @ self.T
        Bddq = np.hstack([-s * kw**2, -c * kw**2]) @ self.T
        return Bq, Bdq, Bddq

    def split(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(Z (P, nv, m), q0 (P, nv))`` of a batch of variables ``X (P, d)``."""
        X = np.atleast_2d(X)
        Z = X[:, : self.nv * self.m].reshape(len(X), self.nv, self.m)
        q0 = (
            X[:, self.nv * self.m :] if self.spec.optimize_offsets else np.broadcast_to(self.spec.q0, (len(X), self.nv))
        )
        return Z, q0

    def join(self, Z: np.ndarray, q0: np.ndarray | None = None) -> np.ndarray:
        """Inverse of :meth:`split`."""
        X = Z.reshape(len(Z), -1)
        return np.hstack([X, q0]) if self.spec.optimize_offsets else X

    def trajectory(self, x: np.ndarray, meta: dict | None = None) -> FourierTrajectory:
        """The Fourier trajectory of variables ``x (d,)``."""
        Z, q0 = self.split(np.asarray(x, float)[None, :])
        C = Z[0] @ self.T.T  # (nv, 2N)
        return FourierTrajectory(
            self.model.joint_names, self.w, q0[0].copy(), C[:, : self.N], C[:, self.N :], meta=dict(meta or {})
        )

    def variables(self, trajectory: FourierTrajectory) -> np.ndarray:
        """Variables ``x`` of a trajectory of this problem's form (least squares if it is not exactly of it)."""
        C = np.hstack([trajectory.a, trajectory.b])  # (nv, 2N)
        Z = np.linalg.lstsq(self.T, C.T, rcond=None)[0].T
        return self.join(Z[None], trajectory.q0[None, :])[0]

    def _basis_for(self, t: np.ndarray | None):
        if t is None or t is self.times:
            return self._basis_design
        if t is self.check_times:
            return self._basis_check
        return self._basis_at(t)

    def states(self, X: np.ndarray, t: np.ndarray | None = None):
        """q, dq, ddq ``(P, n, nv)`` of a batch at the design samples (default) or at times ``t``."""
        Bq, Bdq, Bddq = self._basis_for(t)
        Z, q0 = self.split(X)
        q = np.einsum("nm,pjm->pnj", Bq, Z) + q0[:, None, :]
        return q, np.einsum("nm,pjm->pnj", Bdq, Z), np.einsum("nm,pjm->pnj", Bddq, Z)

    # ------------------------------------------------------------------ bounds and limits
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the variables for the metaheuristics: each coefficient of harmonic k at most the largest
        amplitude that harmonic could have alone (position room, dq_max/(kω), ddq_max/(kω)²); offsets in range."""
        s = self.spec
        room = np.minimum(s.q0 - s.lower, s.upper - s.q0)
        if s.optimize_offsets:
            room = 0.5 * (s.upper - s.lower)
        kw = self.harmonic_of * self.w
        B = np.minimum.reduce(
            [
                np.broadcast_to(room[:, None], (self.nv, self.m)),
                s.velocity[:, None] / kw[None, :],
                s.acceleration[:, None] / kw[None, :] ** 2,
            ]
        )
        upper = B.reshape(-1)
        lower = -upper
        if s.optimize_offsets:
            lower = np.concatenate([lower, s.lower])
            upper = np.concatenate([upper, s.upper])
        return lower, upper

    def linear_constraints(self) -> tuple[np.ndarray, np.ndarray]:
        """``A x <= b``: position, velocity and acceleration limits of every joint on the check grid."""
        s = self.spec
        Bq, Bdq, Bddq = self._basis_check
        n = len(self.check_times)
        rows, rhs = [], []
        for j in range(self.nv):
            block = np.zeros((6 * n, self.d))
            cols = slice(j * self.m, (j + 1) * self.m)
            block[0 * n : 1 * n, cols], block[1 * n : 2 * n, cols] = Bq, -Bq
            block[2 * n : 3 * n, cols], block[3 * n : 4 * n, cols] = Bdq, -Bdq
            block[4 * n : 5 * n, cols], block[5 * n : 6 * n, cols] = Bddq, -Bddq
            if s.optimize_offsets:
                q0col = self.nv * self.m + j
                block[0:n, q0col], block[n : 2 * n, q0col] = 1.0, -1.0
                b_pos = np.concatenate([np.full(n, s.upper[j]), np.full(n, -s.lower[j])])
            else:
                b_pos = np.concatenate([np.full(n, s.upper[j] - s.q0[j]), np.full(n, s.q0[j] - s.lower[j])])
            rows.append(block)
            rhs.append(np.concatenate([b_pos, np.full(2 * n, s.velocity[j]), np.full(2 * n, s.acceleration[j])]))
        return np.vstack(rows), np.concatenate(rhs)

    def scale_into_limits(self, X: np.ndarray, t: np.ndarray | None = None, safety: float = 0.0) -> np.ndarray:
        """Scale each joint's coefficients of every candidate by the largest factor ≤ 1 that puts its
        position, velocity and acceleration inside the limits on grid ``t`` (default: the check grid)
        — the parametrisation that makes every metaheuristic candidate feasible.  Offsets are clipped into
        their range first.  ``safety`` shrinks the factor by that fraction (for a margin between grid points)."""
        s = self.spec
        X = np.array(np.atleast_2d(X), dtype=float)
        if s.optimize_offsets:
            X[:, self.nv * self.m :] = np.clip(X[:, self.nv * self.m :], s.lower, s.upper)
        q, dq, ddq = self.states(X, self.check_times if t is None else t)
        Z, q0 = self.split(X)
        dev = q - q0[:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            up = np.where(dev > 0, (s.upper - q0)[:, None, :] / dev, np.inf).min(axis=1)
            down = np.where(dev < 0, (s.lower - q0)[:, None, :] / dev, np.inf).min(axis=1)
            v = s.velocity / np.abs(dq).max(axis=1)
            a = s.acceleration / np.abs(ddq).max(axis=1)
        factor = np.minimum.reduce([np.ones_like(up), up, down, v, a]) * (1 - safety)
        factor = np.clip(np.nan_to_num(factor, nan=1.0, posinf=1.0), 0.0, 1.0)
        return self.join(Z * factor[:, :, None], q0)

    # ------------------------------------------------------------------ criterion
    def _regressors(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Full stacked regressors ``(P·n·nv, p)`` and base regressors ``(P, n·nv, nb)`` of a batch."""
        P, n, nv = len(X), len(self.times), self.nv
        q, dq, ddq = self.states(X)
        W = regressor(
            self.model, q.reshape(-1, nv), _clean_rest(dq.reshape(-1, nv)), ddq.reshape(-1, nv), self.spec.terms
        )
        self.nfev += P
        self.regressor_samples += P * n
        return W, self.base.columns(W).reshape(P, n * nv, -1)

    def evaluate(self, X: np.ndarray, *, torque: bool = False):
        """Criterion values ``(P,)`` of a batch (``cond``: condition number; ``logdet``: −log det(WᵀW));
        with ``torque``, also the nominal torques ``(P, samples, nv)`` at the design samples."""
        X = np.atleast_2d(X)
        W, Wb = self._regressors(X)
        with np.errstate(divide="ignore", invalid="ignore"):
            sv = np.linalg.svd(Wb, compute_uv=False)
            if self.spec.criterion == "cond":
                values = np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
            else:
                values = np.where(sv[:, -1] > 0, -2 * np.sum(np.log(sv), axis=1), np.inf)
        if torque:
            return values, (W @ self.theta).reshape(len(X), len(self.times), self.nv)
        return values

    def objective_and_gradient(self, x: np.ndarray, h: float = 1e-7, *, torque: bool = False):
        """``(f, grad, tau, tau_jac)`` at ``x``.

        ``f``: log cond(W_b) (criterion ``cond``) or −log det(W_bᵀW_b) (``logdet``).  The gradient uses the
        singular vectors of W_b(x): ``dσ_i = u_iᵀ dW v_i``.  For ``cond`` it is exact: ``W·v`` is the
        inverse dynamics of a model whose inertial parameters are ``v`` (the regressor is linear in them),
        so ``d(W v)`` with respect to each sample's q, dq, ddq is Pinocchio's RNEA derivatives of that model
        (:meth:`_contract`) — three RNEA-derivative passes per sample, whatever the number of design
        variables.  For ``logdet`` it uses forward differences of step ``h`` of each sample's regressor row
        (exact for ddq).  Joint-term columns: analytic (Coulomb: 0 almost everywhere).  The chain rule
        through the Fourier basis gives d/dx.  With ``torque``: the nominal torques ``tau (samples, nv)``
        and their Jacobian ``tau_jac (samples·nv, d)`` (RNEA derivatives of the nominal model)."""
        x = np.asarray(x, dtype=float)
        n, nv = len(self.times), self.nv
        q, dq, ddq = (v[0] for v in self.states(x[None, :]))
        dq = _clean_rest(dq)
        if self.spec.criterion == "cond":
            W0 = regressor(self.model, q, dq, ddq, self.spec.terms)
            D = None
            self.regressor_samples += n
        else:
            W0, D = self._difference_derivatives(q, dq, ddq, h)
        self.nfev += 1
        Wb = self.base.columns(W0)
        tau = tau_jac = None
        try:
            U, sv, Vt = np.linalg.svd(Wb, full_matrices=False)
        except np.linalg.LinAlgError:
            sv = np.zeros(1)
        if not sv[-1] > 0:
            f, G = np.inf, np.zeros((3 * nv, n))
        else:
            cols = self.base.independent

            def full(v):  # a vector over the base columns, spread over all columns (zeros elsewhere)
                out = np.zeros(W0.shape[-1])
                out[cols] = v
                return out

            if self.spec.criterion == "cond":
                f = float(np.log(sv[0] / sv[-1]))
                G = self._contract(
                    q,
                    dq,
                    ddq,
                    [full(Vt[0]), full(Vt[-1])],
                    [U[:, 0].reshape(n, nv) / sv[0], -U[:, -1].reshape(n, nv) / sv[-1]],
                )
            else:
                f = float(-2 * np.sum(np.log(sv)))
                pinv_t = np.zeros((n * nv, D.shape[-1]))
                pinv_t[:, cols] = (U / sv) @ Vt  # (W_b⁺)ᵀ: d log det(W_bᵀW_b) = 2 <(W_b⁺)ᵀ, dW_b>
                G = -2 * (D.reshape(len(D), n, -1) * pinv_t.reshape(n, -1)).sum(-1)
        grad = self._chain(G)
        if torque:
            tau = (W0 @ self.theta).reshape(n, nv)
            ni = 10 * nv
            dtau = np.moveaxis(self._rnea_derivatives(self.model.pin_model, q, dq, ddq), 3, 1)  # (3, nv, n, nv)
            dtau = dtau.reshape(3 * nv, n, nv) + (self._term_derivatives() @ self.theta[ni:])[:, None, :]
            tau_jac = self._chain_rows(dtau)
        return f, grad, tau, tau_jac

    def _difference_derivatives(self, q, dq, ddq, h):
        """Regressor ``W (n·nv, p)`` at the samples and ``D (3nv, n, nv, p)``: d(row of sample s)/d(q_j, dq_j,
        ddq_j) by forward differences of step ``h`` (rigid-body columns), analytic for the term columns."""
        n, nv = len(q), self.nv
        k = 1 + 3 * nv
        Q, DQ, DDQ = (np.broadcast_to(v, (k, n, nv)).copy() for v in (q, dq, ddq))
        for j in range(nv):
            Q[1 + j, :, j] += h
            DQ[1 + nv + j, :, j] += h
            DDQ[1 + 2 * nv + j, :, j] += h
        W = regressor(self.model, Q.reshape(-1, nv), DQ.reshape(-1, nv), DDQ.reshape(-1, nv), self.spec.terms)
        self.regressor_samples += k * n
        W = W.reshape(k, n, nv, -1)
        D = (W[1:] - W[0]) / h
        ni = 10 * nv
        D[:, :, :, ni:] = self._term_derivatives()[:, None, :, :]
        return W[0].reshape(n * nv, -1), D

    def _term_derivatives(self) -> np.ndarray:
        """``(3nv, nv, nt)``: d(term column of joint row i)/d(q_j, dq_j, ddq_j), the same at every sample:
        1 for viscous friction (dq) and armature (ddq), G[m, i]·G[m, k] for their motor forms, 0 otherwise
        (Coulomb: 0 almost everywhere)."""
        if getattr(self, "_term_d", None) is not None:
            return self._term_d
        nv, terms = self.nv, self.spec.terms
        nt = len(terms.joint)
        D = np.zeros((3 * nv, nv, _term_count(self.model, terms)))
        for t, term in enumerate(terms.joint):
            for j in range(nv):
                col = j * nt + t
                if term.name == "fv":
                    D[nv + j, j, col] = 1.0
                elif term.name == "armature":
                    D[2 * nv + j, j, col] = 1.0
        if terms.motor:  # column G[m, j]·(G·dq)_m: derivative G[m, j]·G[m, k] with respect to dq_k (ddq_k)
            G, ntm = self.model.drives.matrix, len(terms.motor)
            for t, term in enumerate(terms.motor):
                if term.suffix not in ("fv", "armature"):
                    continue
                block = nv if term.suffix == "fv" else 2 * nv
                for m in range(G.shape[0]):
                    D[block : block + nv, :, nt * nv + m * ntm + t] = np.outer(G[m], G[m])
        self._term_d = D
        return D

    def _rnea_derivatives(self, pin_model, q, dq, ddq) -> np.ndarray:
        """``(3, n, nv, nv)``: ∂τ/∂q, ∂τ/∂dq, ∂τ/∂ddq of the Pinocchio model ``pin_model`` at each sample
        (``[k, s, i, j]`` = ∂τ_i/∂state_j at sample s)."""
        n, nv = q.shape
        out = np.empty((3, n, nv, nv))
        data = pin_model.createData()
        rnea_d = pin.computeRNEADerivatives
        conf = self.model.configuration if self.model.continuous else None
        for s in range(n):
            a, b, c = rnea_d(pin_model, data, conf(q[s]) if conf else q[s], dq[s], ddq[s])
            out[0, s], out[1, s], out[2, s] = a, b, c
        M = out[2]  # Pinocchio fills the upper triangle of the mass matrix only
        low = np.tril_indices(nv, -1)
        M[:, low[0], low[1]] = M[:, low[1], low[0]]
        self.regressor_samples += n
        return out

    def _contract(self, q, dq, ddq, vectors: list[np.ndarray], weights: list[np.ndarray]) -> np.ndarray:
        """``G (3nv, n)`` = Σ_r Σ_i weights[r][s, i]·d(W(s) vectors[r])_i/d(state_j(s)), exactly.

        ``W v`` restricted to the inertial columns is the inverse dynamics of a model whose inertial
        parameters are ``v``; a parameter vector need not be a physical body (its mass can be 0), so every
        body gets a shift ``c·e`` (mass c at the joint, inertia c·1, c > 2 max|v|) and the shift's own
        derivatives (one more pass) are subtracted — RNEA is linear in the inertial parameters."""
        nv, ni = self.nv, 10 * self.nv
        e = np.tile([1.0, 0, 0, 0, 1, 0, 1, 0, 0, 1], nv)
        c = 1.0 + 2.0 * max(np.abs(v[:ni]).max() for v in vectors)
        pm = self._scratch_model()
        Dt = self._term_derivatives()
        G = np.zeros((3 * nv, len(q)))
        shift_weight = 0.0
        for v, u in zip(vectors, weights):
            self._set_inertias(pm, v[:ni] + c * e)
            R = self._rnea_derivatives(pm, q, dq, ddq)
            G += np.einsum("ksij,si->kjs", R, u).reshape(3 * nv, -1)
            G += (Dt @ v[ni:]) @ u.T
            shift_weight = shift_weight + u
        self._set_inertias(pm, c * e)
        R = self._rnea_derivatives(pm, q, dq, ddq)
        G -= np.einsum("ksij,si->kjs", R, shift_weight).reshape(3 * nv, -1)
        return G

    def _scratch_model(self):
        if getattr(self, "_scratch", None) is None:
            self._scratch = pin.Model(self.model.pin_model)
        return self._scratch

    def _set_inertias(self, pin_model, theta: np.ndarray) -> None:
        for i in range(self.nv):
            pin_model.inertias[i + 1] = pin.Inertia.FromDynamicParameters(theta[10 * i : 10 * i + 10])

    def _chain(self, G: np.ndarray) -> np.ndarray:
        """d/dx of Σ_s G[type_j, s]·d(state_j(s)): G is (3nv, n) per (q_j, dq_j, ddq_j) and sample."""
        Bq, Bdq, Bddq = self._basis_design
        nv = self.nv
        grad = np.concatenate([Bq.T @ G[j] + Bdq.T @ G[nv + j] + Bddq.T @ G[2 * nv + j] for j in range(nv)])
        if self.spec.optimize_offsets:
            grad = np.concatenate([grad, G[:nv].sum(axis=1)])
        return grad

    def _chain_rows(self, dtau: np.ndarray) -> np.ndarray:
        """Jacobian ``(n·nv, d)`` of per-sample outputs whose state derivatives are ``dtau (3nv, n, nv)``."""
        Bq, Bdq, Bddq = self._basis_design
        n, nv, m = len(self.times), self.nv, self.m
        J = np.zeros((n, nv, self.d))
        for j in range(nv):
            cols = slice(j * m, (j + 1) * m)
            J[:, :, cols] = (
                dtau[j][:, :, None] * Bq[:, None, :]
                + dtau[nv + j][:, :, None] * Bdq[:, None, :]
                + dtau[2 * nv + j][:, :, None] * Bddq[:, None, :]
            )
            if self.spec.optimize_offsets:
                J[:, :, nv * m + j] = dtau[j]
        return J.reshape(n * nv, self.d)

    def torque_violation(self, tau: np.ndarray) -> np.ndarray:
        """Worst relative torque excess per candidate (0 when within the limits)."""
        limit = self.spec.torque
        excess = (np.abs(tau) - limit) / np.where(np.isfinite(limit), limit, 1.0)
        excess = np.where(np.isfinite(limit), excess, -np.inf)
        return np.maximum(excess.max(axis=(1, 2)), 0.0)


# ====================================================================================== results
@dataclass
class MultistartOptions:
    """Settings of the default ``slsqp`` design: a two-phase SLSQP multistart.

    Phase 1 (search): ``starts`` local searches on a cheaper problem — ``search_samples`` samples per
    period (None: ``max(50, 12·harmonics)``, at most ``samples``) and limits on a grid of twice that —
    each from the best of ``screen`` random feasible candidates, with loose tolerances (``maxiter``,
    ``ftol``).  Phase 2 (polish): the ``polish`` best distinct results are refined on the full problem
    (``samples`` per period, limits on a grid of ``2·samples``) with ``polish_maxiter`` and ``polish_ftol``.
    ``time_limit`` [s]: no new phase-1 start after it (None: no limit).

    ``starts`` and ``polish`` left at None depend on the robot's size (:meth:`resolved`): 128 and 4 up to
    ``SMALL_ROBOT`` (4) joints, 12 and 1 above — on a 6- or 7-DOF arm one search start costs 1.5–2 s and
    one polish 10–25 s here, and this keeps the default design of those arms under a minute.
    """

    starts: int | None = None
    screen: int = 8
    polish: int | None = None
    search_samples: int | None = None
    maxiter: int = 100
    ftol: float = 1e-5
    polish_maxiter: int = 300
    polish_ftol: float = 1e-9
    time_limit: float | None = None

    def resolved(self, nv: int) -> "MultistartOptions":
        """These options with ``starts`` and ``polish`` filled in for a robot of ``nv`` joints."""
        small = nv <= SMALL_ROBOT
        return replace(
            self,
            starts=(128 if small else 12) if self.starts is None else self.starts,
            polish=(4 if small else 1) if self.polish is None else self.polish,
        )


#: Names accepted by :func:`design_excitation` (``slsqp`` plus the population-based optimisers).
def design_optimizers() -> list[str]:
    return ["slsqp", *OPTIMIZERS]


@dataclass
class ExcitationResult:
    """A designed excitation: the trajectory and what the design reached."""

    trajectory: FourierTrajectory
    spec: ExcitationSpec
    condition_number: float
    log_det: float
    extremes: dict
    usage: dict
    feasible: bool
    optimizer: str
    optimizer_options: dict
    seed: int | None
    seconds: float
    history: np.ndarray
    nfev: int
    tau_abs_max: np.ndarray | None = None
    details: dict = field(default_factory=dict)

    @property
    def criterion(self) -> str:
        """The criterion minimised: ``cond`` (condition number) or ``logdet`` (D-optimal)."""
        return self.spec.criterion

    def to_dict(self) -> dict:
        """The JSON form: the trajectory (FourierTrajectory's keys, radians) plus the design report."""
        report = {
            "condition_number": float(self.condition_number),
            "criterion": self.spec.criterion,
            "log_det": float(self.log_det),
            "feasible": bool(self.feasible),
            "rest_start": bool(self.spec.rest_start),
            "samples": int(self.spec.samples),
            "terms": self.spec.terms.names,
            "limits": self.spec.limits_dict(),
            "margin": float(self.spec.margin),
            "extremes": self.extremes,
            "usage": self.usage,
            "optimizer": self.optimizer,
            "optimizer_options": self.optimizer_options,
            "seed": self.seed,
            "seconds": round(float(self.seconds), 3),
            "nfev": int(self.nfev),
            "history": [float(h) for h in self.history],
            "spec": self.spec.source,
            "urdf": self.details.get("urdf"),
            "robot": self.details.get("robot"),
        }
        report.update({k: v for k, v in self.details.items() if k not in report})
        traj = FourierTrajectory(
            self.trajectory.joints,
            self.trajectory.base_frequency,
            self.trajectory.q0,
            self.trajectory.a,
            self.trajectory.b,
            meta=report,
        )
        return traj.to_dict()

    def save(self, path: str | os.PathLike) -> Path:
        """Write the JSON form atomically (readable by :meth:`FourierTrajectory.load`)."""
        return write_json(path, self.to_dict())


def evaluate_trajectory(
    model: RobotModel, trajectory: FourierTrajectory, spec: ExcitationSpec, *, base: BaseParameters | None = None
) -> dict:
    """Condition number, log det, dense-grid extremes, limit usage and feasibility of a trajectory under a spec."""
    _check_joints(model, trajectory)
    base = base or base_parameters(model, spec.terms)
    ext = trajectory_extremes(trajectory)
    tau = torque_extremes(model, trajectory, spec.terms) if spec.has_torque_limits else None
    if tau is not None:
        for j, name in enumerate(trajectory.joints):
            ext[name]["tau_abs_max"] = float(tau[j])
    return {
        "condition_number": condition_number(model, trajectory, spec.terms, spec.samples, base),
        "log_det": log_det_information(model, trajectory, spec.terms, spec.samples, base),
        "extremes": ext,
        "usage": limit_usage(ext, spec, tau, trajectory.q0),
        "feasible": is_feasible(ext, spec, tau),
        "tau_abs_max": tau,
        "rest_start": trajectory.starts_at_rest(),
    }


def _final_repair(problem: DesignProblem, x: np.ndarray) -> tuple[np.ndarray, FourierTrajectory]:
    """Scale x into the limits on the dense grid (exact extremes); returns the new x and trajectory."""
    tr = problem.trajectory(x)
    if is_feasible(trajectory_extremes(tr), problem.spec):
        return x, tr
    dense = sample_times(problem.spec.period, DENSE_SAMPLES)
    for safety in (1e-9, 1e-7, 1e-5, 1e-3):
        x2 = problem.scale_into_limits(x[None, :], dense, safety=safety)[0]
        tr = problem.trajectory(x2)
        if is_feasible(trajectory_extremes(tr), problem.spec):
            return x2, tr
    return x2, tr


# ====================================================================================== design
def design_excitation(
    model: RobotModel,
    spec: ExcitationSpec | None = None,
    *,
    optimizer: str = "slsqp",
    options: dict | None = None,
    seed: int = 0,
    progress: bool | None = None,
    x0: np.ndarray | None = None,
) -> ExcitationResult:
    """Design an excitation trajectory for ``model`` under ``spec`` (default: :func:`spec_for` the model).

    ``optimizer``: ``"slsqp"`` (gradient-based multistart, :class:`MultistartOptions`) or a name of
    :data:`pinid.optimizers.OPTIMIZERS` (``pso``, ``woa``, ``ewoa``, ``de``) with their options;
    ``options``: settings of that optimiser (dict); ``seed``: the random seed (same seed → same result);
    ``x0``: a starting point (design variables, see :class:`DesignProblem`).

    Raises SpecError when the limits cannot be met; returns an :class:`ExcitationResult` whose trajectory
    is inside the limits on a dense grid (``feasible`` is False only if torque limits could not be met).
    BLAS runs single-threaded meanwhile: the work is many small matrix operations, which OpenBLAS's
    threads slow down (up to 4× on 2 cores) and make irreproducible.
    """
    model = as_robot(model)
    spec = spec or spec_for(model)
    with single_threaded_blas():
        return _design(model, spec, optimizer, options, seed, progress, x0)


def _design(model, spec, optimizer, options, seed, progress, x0) -> ExcitationResult:
    start = time.perf_counter()
    problem = DesignProblem(model, spec)
    rng = np.random.default_rng(seed)
    options = dict(options or {})
    name = optimizer.lower()
    if name == "slsqp":
        known = list(MultistartOptions.__dataclass_fields__)
        unknown = [k for k in options if k not in known]
        if unknown:
            raise SpecError(f"slsqp: unknown option(s) {', '.join(unknown)} (options: {', '.join(known)})")
        opts = MultistartOptions(**options)
        option_numbers(opts, "slsqp")
        opts = opts.resolved(model.nv)
        x, history, extra = _multistart(problem, opts, rng, progress, x0)
        used_options = asdict(opts)
    elif name in OPTIMIZERS:
        opt = get_optimizer(name, **options)
        x, history, extra = _metaheuristic(problem, opt, rng, progress, x0)
        used_options = asdict(opt.options)
    else:
        raise SpecError(f"unknown optimizer {optimizer!r}, expected one of {', '.join(design_optimizers())}")
    x, traj = _final_repair(problem, x)
    ev = evaluate_trajectory(model, traj, spec, base=problem.base)
    seconds = time.perf_counter() - start
    nfev = problem.nfev + int(extra.pop("search_nfev", 0))
    samples = problem.regressor_samples + int(extra.pop("search_regressor_samples", 0))
    details = {
        "robot": model.name,
        "urdf": str(model.urdf_path) if model.urdf_path else None,
        "regressor_samples": samples,
        **extra,
    }
    return ExcitationResult(
        traj,
        spec,
        ev["condition_number"],
        ev["log_det"],
        ev["extremes"],
        ev["usage"],
        ev["feasible"],
        name,
        used_options,
        seed,
        seconds,
        np.asarray(history, float),
        nfev,
        ev["tau_abs_max"],
        details,
    )


def _local_search(problem: DesignProblem, x: np.ndarray, maxiter: int, ftol: float) -> tuple[np.ndarray, float, int]:
    """SLSQP from ``x`` with the kinematic limits as linear constraints (and torque limits as nonlinear ones);
    returns the result scaled into the limits on the check grid, its criterion value and the SLSQP
    iterations.  Gradients: :meth:`DesignProblem.objective_and_gradient`."""
    from scipy.optimize import minimize

    A, b = problem.linear_constraints()
    torque = problem.spec.has_torque_limits
    h = 1e-7
    cache: dict = {}

    def batch(x: np.ndarray):
        key = x.tobytes()
        if key not in cache:
            cache.clear()
            cache[key] = problem.objective_and_gradient(x, h, torque=torque)
        return cache[key]

    def fun(x):
        f, g, _, _ = batch(x)
        if not np.isfinite(f):
            return 1e10, np.zeros_like(x)
        return f, np.where(np.isfinite(g), g, 0.0)

    constraints = [{"type": "ineq", "fun": lambda x: b - A @ x, "jac": lambda x: -A}]
    if torque:
        limit = problem.spec.torque
        finite = np.isfinite(np.tile(limit, len(problem.times)))
        lim = np.tile(limit, len(problem.times))[finite]

        def tau_con(x):
            tau = batch(x)[2].reshape(-1)[finite]
            return np.concatenate([lim - tau, lim + tau])

        def tau_jac(x):
            J = batch(x)[3][finite]
            return np.vstack([-J, J])

        constraints.append({"type": "ineq", "fun": tau_con, "jac": tau_jac})
    res = minimize(
        fun,
        x,
        jac=True,
        method="SLSQP",
        constraints=constraints,
        options={"maxiter": int(maxiter), "ftol": float(ftol)},
    )
    # SLSQP leaves tolerance-level violations: scale into the limits; and when it stops on a failed line
    # search its last iterate can be worse than where it started: keep the better of the two
    X = problem.scale_into_limits(np.vstack([res.x, x]))
    out = problem.evaluate(X, torque=torque)
    if torque:
        values, tau = out
        values = np.where(problem.torque_violation(tau) > 1e-6, np.inf, values)
    else:
        values = out
    k = 0 if values[0] <= values[1] else 1
    return X[k], float(values[k]), int(res.nit)


def _multistart(
    problem: DesignProblem,
    opts: MultistartOptions,
    rng: np.random.Generator,
    progress: bool | None,
    x0: np.ndarray | None,
):
    """Two-phase SLSQP multistart (see :class:`MultistartOptions`); returns (x, history, extra).

    ``history``: best criterion value (on the full problem's samples) after each polished candidate,
    preceded by phase 1's best values per start (on the search samples)."""
    for key in ("starts", "screen", "polish", "maxiter", "polish_maxiter"):
        value = getattr(opts, key)
        if int(value) != value or value < 1:
            raise SpecError(f"slsqp: {key} {value!r}, expected a positive integer")
    start_time = time.perf_counter()
    spec = problem.spec
    ns = opts.search_samples or max(50, 12 * spec.harmonics)
    ns = int(min(ns, spec.samples))
    if ns * problem.nv < problem.base.count:
        ns = spec.samples
    search = DesignProblem(problem.model, spec.replace(samples=ns), check_samples=2 * ns, base=problem.base)
    lower, upper = search.box()
    n_screen = opts.starts * opts.screen
    X = search.scale_into_limits(lower + rng.random((n_screen, search.d)) * (upper - lower))
    values = np.concatenate([search.evaluate(X[i : i + 256]) for i in range(0, n_screen, 256)])
    starts = X[np.argsort(values, kind="stable")[: opts.starts]]
    if x0 is not None:
        starts = np.vstack([search.scale_into_limits(np.atleast_2d(x0)), starts])[: opts.starts]
    found: list[tuple[float, np.ndarray]] = []
    history: list[float] = []
    best = np.inf
    with progress_bar(len(starts) + opts.polish, "slsqp", enabled=progress) as bar:
        for i, xs in enumerate(starts):
            if opts.time_limit is not None and i > 0 and time.perf_counter() - start_time > opts.time_limit:
                break
            x, value, _ = _local_search(search, xs, opts.maxiter, opts.ftol)
            found.append((value, x))
            best = min(best, value)
            history.append(best)
            bar.update(1)
            # phase 1's values are on the search grid (ns samples per period), not the design's: say so, so
            # that the polished result (on the design's samples, the value reported) is not read as worse
            bar.set_postfix_str(f"search best {best:.6g} ({ns} samples/period)", refresh=False)
        found.sort(key=lambda r: r[0])
        chosen: list[np.ndarray] = []
        for value, x in found:  # distinct candidates only
            if len(chosen) == opts.polish or not np.isfinite(value):
                break
            if all(np.linalg.norm(x - c) > 1e-6 * (1 + np.linalg.norm(c)) for c in chosen):
                chosen.append(x)
        best_x, best_f = None, np.inf
        polished = []
        for x in chosen:
            x, value, _ = _local_search(
                problem, problem.scale_into_limits(x[None, :])[0], opts.polish_maxiter, opts.polish_ftol
            )
            repaired, _ = _final_repair(problem, x)  # as the result will be: within the limits on the dense grid
            if np.isfinite(value) and not np.array_equal(repaired, x):
                x, value = repaired, float(problem.evaluate(repaired[None, :])[0])
            polished.append(value)
            if value < best_f:
                best_x, best_f = x, value
            history.append(best_f)
            bar.update(1)
            bar.set_postfix_str(f"polished best {best_f:.6g}", refresh=False)  # the design's criterion
    if best_x is None:
        best_x = problem.scale_into_limits(starts[:1])[0]
    return (
        best_x,
        history,
        {
            "starts_run": len(found),
            "search_samples": ns,
            "search_nfev": search.nfev,
            "search_regressor_samples": search.regressor_samples,
            "polished_values": polished,
        },
    )


def _metaheuristic(problem: DesignProblem, opt, rng: np.random.Generator, progress: bool | None, x0: np.ndarray | None):
    """A population-based optimiser on the box; limits by scaling (kinematic) and penalty (torque)."""
    lower, upper = problem.box()
    torque = problem.spec.has_torque_limits

    def fitness(X: np.ndarray) -> np.ndarray:
        Xs = problem.scale_into_limits(X)
        if not torque:
            return problem.evaluate(Xs)
        values, tau = problem.evaluate(Xs, torque=True)
        viol = problem.torque_violation(tau)
        return np.where(viol > 0, 1e6 * (1 + viol) + values, values)

    res = opt.minimize(fitness, lower, upper, rng=rng, x0=x0, progress=progress)
    x = problem.scale_into_limits(res.x[None, :])[0]
    return x, res.history, {"message": res.message, "iterations": res.nit}
