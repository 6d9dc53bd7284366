"""The digital twin: a leg (or any fixed-base robot) tracking a trajectory in closed loop, recorded.

:func:`simulate` integrates the rigid-body dynamics of a :class:`~pinid.model.robot.RobotModel` (the truth)
with joint friction, driven by a PD or PID controller with optional feed-forward, and returns what a rig
would record — noisy, quantised positions and noisy torques at the sample rate — plus a truth dict
(standard and base parameters, noise levels, seed, rates) and the noise-free signals.

Model, exactly the regressor's (:mod:`pinid.model.regressor`)::

    tau_applied (+ d) = M(q)·ddq + h(q, dq) + fc·sign(dq) + fv·dq (+ Σ more joint terms)   (fc, fv ≥ 0)

More joint terms of the registry (``Friction.terms``, e.g. the wearer's passive moments, on by default when the
caller hands over the wearer strapped to the robot, :class:`WearerLoad`) act through their own plant laws
(:class:`Plant`); ``d`` is the wearer's involuntary active torque (``WearerLoad.torque``), which moves the leg
but is not in the recorded torque.

**Coulomb friction near zero velocity.**  ``sign(dq)`` makes the equations of motion stiff (set-valued
at dq = 0).  The simulator uses ``fc·tanh(dq / v_s)`` with ``v_s = coulomb_velocity`` (default
0.01 rad/s) and integrates friction implicitly (linearised backward Euler on the velocity), so any
``v_s`` is stable.  The difference to the regressor's ``sign`` is ``fc·(1 − tanh(|dq|/v_s))``: below
1 % of ``fc`` once ``|dq| > 2.65·v_s`` (0.027 rad/s), and at most ``fc`` in a band of a few ``v_s``
around each velocity reversal — a fraction ``≈ (2/π)·2.65·v_s / (amplitude of dq)`` of the samples of a
sinusoidal motion, about 0.5 % for 3 rad/s.  The recorded (applied) torque is exact for the twin's
dynamics; the truth dict states ``v_s`` so that tests can mask those samples.

**Integration.**  The controller runs at ``control_rate`` (zero-order hold on its torque); the plant is
integrated on a finer fixed grid (``integration_rate``, default the smallest multiple of the control
and sample rates ≥ 2 kHz) with a semi-implicit scheme: Pinocchio's ``computeMinverse`` and
``nonLinearEffects`` (the model's damping and friction are zero, friction is added here), implicit
friction, velocity updated first, position by the trapezoidal rule.  The "true" acceleration stored
for each sample is the instantaneous one, ``M⁻¹(τ − h − friction)`` at the sample's state and torque,
so ``rnea(q, dq, ddq) + friction == tau_applied`` holds to rounding at every sample.

**Controller.**  PD: ``Kp = M_jj·ω²``, ``Kd = 2·M_jj·ω``; PID: ``3·M_jj·ω²``, ``3·M_jj·ω``,
``M_jj·ω³`` (all poles at −ω), ``ω = 2π·bandwidth`` and ``M_jj`` the mass-matrix diagonal at the start.
It reads the measured (noisy, quantised) positions and a velocity estimated from them (backward
difference, first-order low-pass at ``velocity_cutoff``) against the desired velocity through the same
low-pass, so that the filter's lag does not become a tracking error.  Feed-forward ("model", default): inverse
dynamics of the desired trajectory with ``feedforward_model`` (default: the truth; give a perturbed
"CAD" model for realism) plus its friction; "gravity" or "none".  Torques are clipped at the URDF effort
limits.  The run starts on the trajectory (q, dq at t = 0).

**Sensors.**  Positions: Gaussian noise ``position_noise`` [rad], then quantised to
``encoder_resolution`` [rad] (default 16-bit: 2π/65536).  Torques: Gaussian noise ``torque_noise``
[N·m] per joint (default ``torque_noise_percent`` = 1 % of each joint's peak applied torque).  Velocities (``record_velocity``):
true velocity plus Gaussian ``velocity_noise`` [rad/s].  Everything random comes from ``seed``.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, replace
from collections.abc import Mapping, Sequence

import numpy as np
import pinocchio as pin

from pinid.checks import as_floats, count, number, of_type
from pinid.data.dataset import Dataset
from pinid.errors import DataError, DataWarning, SpecError
from pinid.model.robot import RobotModel, as_robot
from pinid.model.floating import FloatingRobotModel
from pinid.excitation.trajectory import FourierTrajectory
from pinid.io import write_json
from pinid.model import terms as _terms
from pinid.model.base import base_parameters
from pinid.model.regressor import parameter_names, standard_parameters
from pinid.model.terms import TermSelection
from pinid.progress import progress as _progress
from pinid.errors import OutputError
from pinid.io import as_path
from pinid.checks import array_like
from pinid.simulation.cad import perturb as perturb
from pinid.simulation.plant import Plant as Plant
from pinid.simulation.plant_checks import (
    LIMIT_OVERSHOOT as LIMIT_OVERSHOOT,
    TRACKING_ERROR_MAX as TRACKING_ERROR_MAX,
    check_mass_matrix,
    check_tracking as check_tracking,
)
from pinid.simulation.trajectories import (
    PAPER_CONVENTIONS as PAPER_CONVENTIONS,
    ZHA2019_TABLE1 as ZHA2019_TABLE1,
    load_trajectory as load_trajectory,
    trajectory_presets as trajectory_presets,
    zha2019_trajectory as zha2019_trajectory,
)


# ---------------------------------------------------------------------------------------------- simulation
def _rates(control_rate: float, sample_rate: float, integration_rate: float | None) -> tuple[int, int, int]:
    for name, r in (("control rate", control_rate), ("sample rate", sample_rate)):
        if not np.isfinite(r) or r <= 0 or float(r) != int(r):
            raise SpecError(f"{name} {r!r}, expected a whole number of Hz > 0")
    c, s = int(control_rate), int(sample_rate)
    base = c * s // math.gcd(c, s)
    if integration_rate is None:
        grid = base * max(1, math.ceil(2000 / base))
    else:
        if (
            not np.isfinite(integration_rate)
            or integration_rate <= 0
            or float(integration_rate) != int(integration_rate)
            or int(integration_rate) % base
        ):
            raise SpecError(
                f"integration rate {integration_rate!r}, expected a whole multiple of {base} Hz "
                f"(the least common multiple of the control and sample rates)"
            )
        grid = int(integration_rate)
    if grid > 200_000:
        raise SpecError(
            f"control rate {c} Hz and sample rate {s} Hz need a {grid} Hz integration grid; "
            "expected rates whose least common multiple is at most 200 kHz"
        )
    return c, s, grid


def _per_joint(value, model: RobotModel, name: str) -> np.ndarray:
    a = (
        np.broadcast_to(np.asarray(value, dtype=float), (model.nv,)).copy()
        if np.ndim(value) == 0
        else np.asarray(value, float)
    )
    if a.shape != (model.nv,) or not np.all(np.isfinite(a)):
        raise SpecError(
            f"{name}: {value!r}, expected one finite number or one per joint ({model.nv}: {model.joint_names})"
        )
    return a


@dataclass(frozen=True)
class Rates:
    """The twin's clocks [Hz]: the controller's ``control`` rate, the recording's ``sample`` rate (default
    the control rate) and the ``integration`` grid (default the smallest common multiple of both ≥ 2 kHz)."""

    control: float = 1000.0
    sample: float | None = None
    integration: float | None = None


@dataclass(frozen=True)
class Controller:
    """The twin's joint controller (module text): ``kind`` "pd" or "pid" with every pole at −2π·``bandwidth``
    [Hz], or the gains ``kp`` [N·m/rad], ``kd`` [N·m·s/rad], ``ki`` [N·m/(rad·s)] (scalar or per joint);
    ``feedforward`` "model" (inverse dynamics of ``feedforward_model``, default the truth), "gravity" or
    "none"; ``velocity_cutoff`` [Hz] of the low-pass on the differentiated positions."""

    kind: str = "pd"
    bandwidth: float = 4.0
    kp: float | Sequence[float] | None = None
    kd: float | Sequence[float] | None = None
    ki: float | Sequence[float] | None = None
    feedforward: str = "model"
    feedforward_model: RobotModel | None = None
    velocity_cutoff: float = 30.0


@dataclass(frozen=True)
class Friction:
    """The plant's joint friction, the laws of :class:`Plant`: ``coulomb`` [N·m] and ``viscous`` [N·m·s/rad]
    per joint (default the URDF's ``<dynamics>``), Coulomb smoothed as ``fc·tanh(dq/coulomb_velocity)``
    [rad/s], and ``terms``: more true joint terms, ``{term name: per-joint values}`` (:func:`plant_terms`;
    None: the wearer's passive moments at their nominal scale 1 when :class:`WearerLoad` carries segments)."""

    coulomb: float | Sequence[float] | None = None
    viscous: float | Sequence[float] | None = None
    coulomb_velocity: float = 0.01
    terms: dict[str, Sequence[float]] | None = None


@dataclass(frozen=True)
class Sensors:
    """What the rig measures: positions with Gaussian ``position_noise`` [rad] quantised to
    ``encoder_resolution`` [rad]; torques with Gaussian ``torque_noise`` [N·m] per joint (default
    ``torque_noise_percent`` % of each joint's peak torque); with ``record_velocity``, velocities with
    Gaussian ``velocity_noise`` [rad/s]."""

    position_noise: float = 2e-5
    encoder_resolution: float = 2 * np.pi / 2**16
    torque_noise: float | Sequence[float] | None = None
    torque_noise_percent: float = 1.0
    record_velocity: bool = False
    velocity_noise: float = 0.01


@dataclass(frozen=True)
class WearerLoad:
    """The wearer a fixed-base twin carries: its ``segments`` strapped to the model, ``{segment: (exo link, mass
    [kg], CoM [m], inertia about the CoM [kg·m²])}`` (:func:`pinid.wearer.attach.wearer_links` of a URDF from
    ``pinid wearer``; the caller finds them: the wearer is a layer above the twin; the truth lists them),
    ``drawn``: ``(table values, drawn values)`` when the model's wearer was drawn away from the tables
    (:func:`pinid.wearer.prior.draw_wearer`), kept in ``truth["wearer"]["drawn"]`` (:func:`drawn_wearer_truth`),
    and ``torque`` [%]: the wearer's involuntary active torque, per joint that percentage of the RMS gravity
    torque along the trajectory (:func:`wearer_disturbance`), which acts on the plant but is not recorded."""

    segments: dict | None = None
    drawn: tuple[dict, dict] | None = None
    torque: float = 0.0

    def __post_init__(self) -> None:
        of_type(self.segments, dict, "WearerLoad segments", "the wearer's segments (a dict) or None")
        of_type(self.drawn, tuple, "WearerLoad drawn", "(table values, drawn values) or None")
        of_type(self.torque, (int, float), "WearerLoad torque", "a percentage", none=False)


#: The flat keywords :func:`simulate` also takes: which option group and field each one sets.
_FLAT = {
    "control_rate": ("rates", "control"),
    "sample_rate": ("rates", "sample"),
    "integration_rate": ("rates", "integration"),
    "bandwidth": ("controller", "bandwidth"),
    "kp": ("controller", "kp"),
    "kd": ("controller", "kd"),
    "ki": ("controller", "ki"),
    "feedforward": ("controller", "feedforward"),
    "feedforward_model": ("controller", "feedforward_model"),
    "velocity_cutoff": ("controller", "velocity_cutoff"),
    **{k: ("friction", k) for k in ("coulomb", "viscous", "coulomb_velocity", "terms")},
    **{
        k: ("sensors", k)
        for k in (
            "position_noise",
            "encoder_resolution",
            "torque_noise",
            "torque_noise_percent",
            "record_velocity",
            "velocity_noise",
        )
    },
}


def simulate(
    model: RobotModel,
    trajectory: FourierTrajectory,
    *,
    seconds: float,
    seed: int = 0,
    rates: Rates | None = None,
    controller: Controller | str | None = None,
    friction: Friction | None = None,
    sensors: Sensors | None = None,
    wearer: WearerLoad | None = None,
    progress: bool | None = False,
    **options,
) -> tuple[Dataset, dict]:
    """Simulate ``model`` (the truth) tracking ``trajectory`` for ``seconds``; return ``(recording, truth)``.

    The recording has t [s], q (measured) [rad], tau (applied plus noise) [N·m], and dq [rad/s] when
    recording velocities.  ``truth`` is JSON-ready except ``truth["signals"]``, a Dataset of the true
    q, dq, ddq (instantaneous) and applied torque at the sample times (see :func:`truth_json`).
    The options come in groups: :class:`Rates`, :class:`Controller` (or its kind, "pd" or "pid"),
    :class:`Friction` (default the URDF's ``<dynamics>``; more plant ``terms``), :class:`Sensors` and the
    :class:`WearerLoad` the robot carries; a group of another type is a one-line SpecError.  Each field of
    the first four can also be given as a keyword (``bandwidth=8``, ``position_noise=0``, ``terms=…``,
    ``coulomb=…``; the rates as ``control_rate``, ``sample_rate``, ``integration_rate``), which overrides the
    group's.  Everything random comes from ``seed``; more in the module text.
    A floating model runs :mod:`pinid.simulation.floating_twin` (``trajectory`` also "gait"; ``sensors`` a
    ``BaseSensors`` or ``noise=``, ``imu_frame=``; rate ``BaseSensors.rate``, else ``rates.sample`` or
    ``rates.control``) and returns a ``TwinRun``, unpacked as ``(recording, truth)`` (a Dataset with floating
    channels); an option of the other kind raises SpecError.
    """
    if isinstance(model, FloatingRobotModel):  # a free flyer is a root joint: one call, the floating twin
        from pinid.simulation.floating_twin import simulate_free_flyer

        fixed = {"controller": controller, "friction": friction, "wearer": wearer, **options}
        return simulate_free_flyer(model, trajectory, seconds, seed, rates, sensors, fixed)
    wrong = [k for k in ("noise", "imu_frame") if k in options] + [t for t in [trajectory] if t == "gait"]
    if wrong or not isinstance(sensors, (Sensors, type(None))):
        raise SpecError(f"{(wrong or ['sensors'])[0]}: for a floating-base model only, {model.name} has a fixed base")
    of_type(rates, Rates, "rates", "a Rates or None")
    of_type(controller, (Controller, str), "controller", "a Controller, its kind ('pd' or 'pid') or None")
    of_type(friction, Friction, "friction", "a Friction or None")
    wearer = of_type(wearer, WearerLoad, "wearer", "a WearerLoad or None") or WearerLoad()
    groups = {
        "rates": rates or Rates(),
        "friction": friction or Friction(),
        "sensors": sensors or Sensors(),
        "controller": Controller(kind=controller) if isinstance(controller, str) else controller or Controller(),
    }
    changes: dict[str, dict] = {}
    for key, value in options.items():
        if key not in _FLAT:
            moved = " (the wearer's options are fields of wearer=WearerLoad(...))" if key.startswith("wearer") else ""
            raise SpecError(f"simulate: unknown option {key!r}{moved}; expected one of {', '.join(sorted(_FLAT))}")
        group, name = _FLAT[key]
        changes.setdefault(group, {})[name] = value
    r, c, f, s = (replace(groups[g], **changes.get(g, {})) for g in ("rates", "controller", "friction", "sensors"))
    recording, truth = _simulate(model, trajectory, seconds, seed, (r, c, f, s), wearer, progress)
    if wearer.drawn is not None:
        truth.setdefault("wearer", {})["drawn"] = drawn_wearer_truth(*wearer.drawn)
    return recording, truth


def _simulate(
    model: RobotModel,
    trajectory: FourierTrajectory,
    seconds: float,
    seed: int,
    groups: tuple[Rates, Controller, Friction, Sensors],
    wearer: WearerLoad,
    progress: bool | None,
) -> tuple[Dataset, dict]:
    """:func:`simulate` with every option resolved, its groups unpacked into one name each, as the body uses them."""
    r, c, f, s = groups
    control_rate, sample_rate, integration_rate = r.control, r.sample, r.integration
    controller, bandwidth, kp, kd, ki = c.kind, c.bandwidth, c.kp, c.kd, c.ki
    feedforward, feedforward_model, velocity_cutoff = c.feedforward, c.feedforward_model, c.velocity_cutoff
    coulomb, viscous, coulomb_velocity, terms = f.coulomb, f.viscous, f.coulomb_velocity, f.terms
    position_noise, encoder_resolution, torque_noise = s.position_noise, s.encoder_resolution, s.torque_noise
    torque_noise_percent, record_velocity, velocity_noise = s.torque_noise_percent, s.record_velocity, s.velocity_noise
    wearer_torque, wearer = wearer.torque, wearer.segments
    model = as_robot(model)
    if not isinstance(trajectory, FourierTrajectory):
        raise SpecError(f"trajectory: got {type(trajectory).__name__}, expected a FourierTrajectory")
    seconds = number(seconds, "seconds")  # a number; its range is checked below (the duration)
    seed = count(seed, "seed")
    if seed >= 2**32:
        raise SpecError(f"seed={seed!r}, expected an integer 0 ≤ seed < 2³²")
    if not np.isfinite(seconds) or seconds <= 0:
        raise SpecError(f"duration {seconds!r} s, expected a duration > 0")
    if controller not in ("pd", "pid"):
        raise SpecError(f"controller {controller!r}, expected 'pd' or 'pid'")
    if feedforward not in ("model", "gravity", "none"):
        raise SpecError(f"feed-forward {feedforward!r}, expected 'model', 'gravity' or 'none'")
    for name, v in (
        ("bandwidth", bandwidth),
        ("coulomb velocity scale", coulomb_velocity),
        ("velocity cut-off", velocity_cutoff),
    ):
        if not np.isfinite(v) or v <= 0:
            raise SpecError(f"{name} {v!r}, expected a value > 0")
    for name, v in (
        ("position noise", position_noise),
        ("encoder resolution", encoder_resolution),
        ("velocity noise", velocity_noise),
    ):
        if not np.isfinite(v) or v < 0:
            raise SpecError(f"{name} {v!r}, expected a value >= 0")
    sample_rate = control_rate if sample_rate is None else sample_rate
    ctrl, smp, grid = _rates(control_rate, sample_rate, integration_rate)
    if velocity_cutoff >= ctrl / 2:
        raise SpecError(
            f"velocity cut-off {velocity_cutoff:g} Hz, expected below half the control rate ({ctrl / 2:g} Hz)"
        )
    n_c, n_s = grid // ctrl, grid // smp
    n_steps = int(round(seconds * grid))
    if n_steps < 2 * n_s:
        raise SpecError(f"duration {seconds:g} s is shorter than two samples at {smp} Hz")
    tr = trajectory.for_joints(model.joint_names, model.name)
    nv = model.nv
    fc = _per_joint(model.coulomb if coulomb is None else coulomb, model, "Coulomb friction")
    fv = _per_joint(model.viscous if viscous is None else viscous, model, "viscous friction")
    if np.any(fc < 0) or np.any(fv < 0):
        raise SpecError(f"friction must be >= 0 (Coulomb {fc.tolist()}, viscous {fv.tolist()})")
    extra = plant_terms(model, terms, wearer)
    wearer = dict(wearer or {})
    if not np.isfinite(wearer_torque) or wearer_torque < 0:
        raise SpecError(f"wearer torque {wearer_torque!r} %, expected a percentage >= 0")

    # desired trajectory at the control instants, and limits
    k_ctrl = np.arange(n_steps // n_c + 1)
    t_ctrl = k_ctrl / ctrl
    qd, dqd, ddqd = tr.evaluate(t_ctrl)
    lo, hi = model.lower, model.upper
    tol = 1e-3  # rad: published trajectories are rounded (seed 001 Table 3 reaches -0.0874 against -0.087)
    for j in range(nv):
        out = np.flatnonzero((qd[:, j] < lo[j] - tol) | (qd[:, j] > hi[j] + tol))
        if out.size:
            k = int(out[0])
            raise SpecError(
                f"trajectory takes joint '{model.joint_names[j]}' to {qd[k, j]:.4g} rad at t = {t_ctrl[k]:.4g} s, "
                f"outside its URDF limits [{lo[j]:.4g}, {hi[j]:.4g}]"
            )

    check_mass_matrix(model, qd[:: max(1, len(qd) // 20)], extra.get("armature"))

    vmax = model.velocity_limit
    over = np.flatnonzero(np.max(np.abs(dqd), axis=0) > vmax * (1 + 1e-9))
    if over.size:
        j = int(over[0])
        warnings.warn(
            f"trajectory reaches {np.max(np.abs(dqd[:, j])):.3g} rad/s on joint '{model.joint_names[j]}', "
            f"above its URDF velocity limit {vmax[j]:.3g} rad/s (simulated anyway)",
            DataWarning,
            stacklevel=3,
        )
    pm, pdata = model.pin_model, model.pin_model.createData()
    cont = bool(model.continuous)
    conf = model.configuration if cont else (lambda x: x)
    # gains
    Mjj = np.diag(pin.crba(pm, pdata, conf(qd[0]))).copy()
    w = 2 * np.pi * bandwidth
    if controller == "pd":
        gains = {"kp": Mjj * w**2, "kd": 2 * Mjj * w, "ki": np.zeros(nv)}
    else:
        gains = {"kp": 3 * Mjj * w**2, "kd": 3 * Mjj * w, "ki": Mjj * w**3}
    for name, v in (("kp", kp), ("kd", kd), ("ki", ki)):
        if v is not None:
            gains[name] = _per_joint(v, model, name)
    Kp, Kd, Ki = gains["kp"], gains["kd"], gains["ki"]
    # feed-forward at the control instants
    ffm = feedforward_model or model
    if feedforward == "model":
        tau_ff = ffm.rnea(qd, dqd, ddqd) + ffm.coulomb * np.sign(dqd) + ffm.viscous * dqd
        motor_terms = _motor_terms(ffm)
        if motor_terms:
            tau_ff += _terms.torque(ffm, motor_terms, _terms.nominal(ffm, motor_terms), qd, dqd, ddqd)
    elif feedforward == "gravity":
        tau_ff = ffm.rnea(qd, np.zeros_like(qd), np.zeros_like(qd))
    else:
        tau_ff = np.zeros_like(qd)
    effort = model.effort_limit
    low = -effort

    # random streams: positions, torques, velocities
    ss = np.random.SeedSequence(int(seed))
    rng_q, rng_tau, rng_v, rng_w = (np.random.default_rng(s) for s in ss.spawn(4))
    g_rms = np.sqrt(np.mean(model.rnea(qd, np.zeros_like(qd), np.zeros_like(qd)) ** 2, axis=0))
    disturbance = wearer_disturbance(t_ctrl, wearer_torque / 100.0 * g_rms, rng_w) if wearer_torque > 0 else None
    g = math.gcd(n_c, n_s)
    q_noise = (
        rng_q.normal(0.0, position_noise, (n_steps // g + 1, nv))
        if position_noise > 0
        else np.zeros((n_steps // g + 1, nv))
    )
    res = float(encoder_resolution)

    def measure(i: int, q: np.ndarray) -> np.ndarray:
        y = q + q_noise[i // g]
        return (y / res).round() * res if res > 0 else y

    # state
    h = 1.0 / grid
    q = qd[0].copy()
    v = dqd[0].copy()
    alpha = math.exp(-2 * math.pi * velocity_cutoff / ctrl)
    beta = 1.0 - alpha
    v_est = dqd[0].copy()
    v_ref = dqd[0].copy()  # desired velocity through the same low-pass as the estimate (no phase mismatch)
    integ = np.zeros(nv)
    q_prev = None
    n_samples = len(range(0, n_steps, n_s))
    rec_t = np.arange(n_samples) / smp
    rec_q = np.empty((n_samples, nv))
    true_q = np.empty((n_samples, nv))
    true_v = np.empty((n_samples, nv))
    true_a = np.empty((n_samples, nv))
    true_tau = np.empty((n_samples, nv))
    plant = Plant(model, fc, fv, coulomb_velocity, extra)
    tau = np.zeros(nv)
    saturated = 0
    s_idx = 0
    bar = None
    if progress is not False:  # None: the caller (the CLI) leaves it to pinid.progress
        bar = _progress(n_steps // n_c, "simulate", enabled=None if progress is None else bool(progress))
    try:
        for i in range(n_steps):
            if i % n_c == 0:
                k = i // n_c
                qm = measure(i, q)
                if q_prev is not None:
                    v_est = alpha * v_est + beta * (qm - q_prev) * ctrl
                    v_ref = alpha * v_ref + beta * dqd[k]
                q_prev = qm
                e = qd[k] - qm
                integ += e / ctrl
                tau = tau_ff[k] + Kp * e + Kd * (v_ref - v_est) + Ki * integ
                clipped = tau.clip(low, effort)  # array methods: the np.* wrappers cost more than the work
                if (clipped != tau).any():
                    saturated += 1
                    tau = clipped
                if bar is not None and k % 1000 == 0 and k:
                    bar.update(1000)
            a, q_new, v_new = plant.step(q, v, tau if disturbance is None else tau + disturbance[i // n_c], h)
            if i % n_s == 0:
                rec_q[s_idx] = qm if i % n_c == 0 else measure(i, q)  # the controller's reading, when it read
                true_q[s_idx], true_v[s_idx], true_a[s_idx], true_tau[s_idx] = q, v, a, tau
                s_idx += 1
            q, v = q_new, v_new
            if not np.isfinite(v).all():
                raise DataError(
                    f"simulation diverged at t = {i * h:.4g} s; expected a stable closed loop "
                    "(lower --bandwidth or raise the control rate)"
                )
    finally:
        if bar is not None:
            bar.close()
    if np.any(np.abs(true_q.ravel()) > 1e6):  # pragma: no cover - diverged without NaN
        raise DataError("simulation diverged; expected a stable closed loop (lower the bandwidth)")
    check_tracking(model, true_q, tr.evaluate(rec_t)[0])

    # sensors
    peak = np.max(np.abs(true_tau), axis=0)
    if torque_noise is None:
        if not np.isfinite(torque_noise_percent) or torque_noise_percent < 0:
            raise SpecError(f"torque noise {torque_noise_percent!r} %, expected a percentage >= 0")
        sigma_tau = torque_noise_percent / 100.0 * peak
    else:
        sigma_tau = _per_joint(torque_noise, model, "torque noise")
        if np.any(sigma_tau < 0):
            raise SpecError(f"torque noise {torque_noise!r}, expected values >= 0 [N·m]")
    rec_tau = true_tau + rng_tau.normal(0.0, 1.0, true_tau.shape) * sigma_tau
    rec_dq = true_v + rng_v.normal(0.0, velocity_noise, true_v.shape) if record_velocity else None
    joints = model.joint_names
    recording = Dataset(
        t=rec_t,
        q=rec_q,
        joints=joints,
        dq=rec_dq,
        tau=rec_tau,
        source="pinid simulate",
        meta={"simulated": True, "seed": int(seed)},
    )
    signals = Dataset(
        t=rec_t, q=true_q, joints=joints, dq=true_v, ddq=true_a, tau=true_tau, source="pinid simulate (truth)"
    )

    terms = TermSelection(names=["fc", "fv"] + list(extra) + _motor_terms(model).names)
    truth_model = model.with_inertial_parameters(model.inertial_parameters(), coulomb=fc, viscous=fv)
    theta = standard_parameters(truth_model, terms)
    for k, p in enumerate(_terms.robot_layout(model, terms)):
        if p.term.name in extra:
            theta[10 * nv + k] = extra[p.term.name][p.index]
    bp = base_parameters(truth_model, terms)
    qd_s, _, _ = tr.evaluate(rec_t)
    err = true_q - qd_s
    truth = {
        "robot": model.name,
        "urdf": str(model.urdf_path) if model.urdf_path else None,
        "joints": joints,
        "locked": model.locked,
        "seed": int(seed),
        "seconds": float(seconds),
        "samples": int(n_samples),
        "rates": {"control": ctrl, "sample": smp, "integration": grid},
        "trajectory": tr.to_dict(),
        "terms": terms.names,
        "standard": {"names": parameter_names(truth_model, terms), "values": theta.tolist()},
        "base": {"names": bp.names, "expressions": bp.expressions(), "values": bp.from_standard(theta).tolist()},
        "friction": {
            "model": "tau = rnea(q, dq, ddq) + fc*sign(dq) + fv*dq (+ G^T*(motor terms at G*dq) with drives); "
            "the simulator uses fc*tanh(dq/v_s)",
            "coulomb": dict(zip(joints, fc.tolist())),
            "viscous": dict(zip(joints, fv.tolist())),
            "coulomb_velocity_scale": float(coulomb_velocity),
        },
        "drives": None if model.drives is None else model.drives.to_dict(),
        "noise": {
            "position_std": float(position_noise),
            "encoder_resolution": res,
            "torque_std": dict(zip(joints, np.asarray(sigma_tau, float).tolist())),
            "velocity_std": float(velocity_noise) if record_velocity else None,
        },
        "controller": {
            "type": controller,
            "bandwidth_hz": float(bandwidth),
            "feedforward": feedforward,
            "feedforward_model": "truth" if feedforward_model is None else "given (e.g. perturbed CAD)",
            "kp": Kp.tolist(),
            "kd": Kd.tolist(),
            "ki": Ki.tolist(),
            "velocity_cutoff_hz": float(velocity_cutoff),
            "saturated_fraction": saturated / max(1, len(k_ctrl) - 1),
        },
        "tracking": {
            "rms_error": dict(zip(joints, np.sqrt(np.mean(err**2, axis=0)).tolist())),
            "max_error": dict(zip(joints, np.max(np.abs(err), axis=0).tolist())),
        },
        "signals": signals,
    }
    if extra or disturbance is not None or wearer:
        truth["wearer"] = {
            "table_segments": {
                s: {"link": lk, "mass": m, "com": c.tolist(), "inertia_about_com": I.tolist()}
                for s, (lk, m, c, I) in wearer.items()
            },
            "terms": {n: dict(zip(joints, v.tolist())) for n, v in extra.items()},
            "active_torque": {
                "percent_of_gravity_rms": float(wearer_torque),
                "rms": dict(zip(joints, (wearer_torque / 100.0 * g_rms).tolist())),
                "band_hz": list(WEARER_BAND),
            },
        }
    return recording, truth


#: Frequency band [Hz] of the wearer's involuntary active torque (slow, voluntary-like movement).
WEARER_BAND = (0.2, 2.0)


def wearer_disturbance(t: np.ndarray, rms: np.ndarray, rng: np.random.Generator, components: int = 16) -> np.ndarray:
    """A smooth random torque (N, nv) [N·m] at times ``t`` [s]: per joint a sum of ``components`` sinusoids,
    frequencies uniform in :data:`WEARER_BAND`, random phases and amplitudes, scaled to exactly ``rms`` [N·m]."""
    t = as_floats(array_like(t, "t"), "t")
    rms = as_floats(rms, "rms")
    if t.ndim != 1 or rms.ndim != 1:
        raise DataError(f"t: shape {t.shape}, rms: shape {rms.shape}; expected (N,) times [s] and (nv,) RMS [N·m]")
    f = rng.uniform(*WEARER_BAND, (components, rms.size))
    phase = rng.uniform(0, 2 * np.pi, (components, rms.size))
    amp = rng.normal(0, 1, (components, rms.size))
    x = np.einsum("kj,nkj->nj", amp, np.sin(2 * np.pi * t[:, None, None] * f + phase))
    return x * (rms / np.maximum(np.sqrt(np.mean(x**2, axis=0)), 1e-300))


def drawn_wearer_truth(table: np.ndarray, drawn: dict) -> dict:
    """The ``wearer["drawn"]`` entry of a twin's truth when its wearer was drawn away from the tables
    (:func:`pinid.wearer.prior.draw_wearer`'s defaults: mass ±25 %, centre of mass ±20 %): the drawn
    wearer's standard parameters per joint and the robot's table (URDF) standard parameters."""
    array_like(table, "table")
    if not isinstance(drawn, dict):
        raise SpecError(f"drawn: got {type(drawn).__name__}, expected the dict of draw_wearer")
    return {
        "mass_percent": 25.0,
        "com_percent": 20.0,
        "wearer_standard": {j: w.tolist() for j, w in drawn.items()},
        "table_standard": table.tolist(),
    }


def plant_terms(model: RobotModel, terms: dict | None = None, wearer: Mapping | None = None) -> dict[str, np.ndarray]:
    """The plant's extra joint terms, checked: ``terms`` or, by default, the wearer's passive moments when
    ``wearer`` (the segments strapped to ``model``, as :func:`simulate` takes them) is given and not empty."""
    model = as_robot(model)
    if wearer is not None and not isinstance(wearer, Mapping):
        raise SpecError(f"wearer: got {type(wearer).__name__}, expected {{segment: (link, mass, com, inertia)}}")
    if terms is None:
        return {"passive": _terms.nominal(model, TermSelection(names=["passive"]))} if wearer else {}
    out = {}
    for name, v in terms.items():
        t = _terms.TERMS.get(name)
        if t is None or t.space != "joint" or name in ("fc", "fv"):
            raise SpecError(
                f"plant term {name!r}, expected a joint term other than fc and fv (give those as "
                f"coulomb/viscous): {[n for n, x in _terms.TERMS.items() if x.space == 'joint' and n not in ('fc', 'fv')]}"
            )
        out[name] = _per_joint(v, model, f"term {name}")
    return out


def _motor_terms(model: RobotModel) -> TermSelection:
    """The motor terms the plant of ``model`` has (all four when its drives carry any nominal value)."""
    d = model.drives
    if d is None or not any(np.any(d.nominal(k) != 0) for k in ("fc", "fv", "armature", "offset")):
        return TermSelection(names=[])
    return TermSelection(names=["motor_fc", "motor_fv", "motor_offset", "motor_armature"])


def truth_json(truth: dict) -> dict:
    """The JSON-ready part of a truth dict (everything but the in-memory ``signals``)."""
    if not isinstance(truth, dict):
        raise SpecError(f"truth: got {type(truth).__name__}, expected the truth dict of simulate")
    return {k: v for k, v in truth.items() if k != "signals"}


def save_truth(path, truth: dict):
    """Write the truth dict (without ``signals``) as JSON, atomically."""
    path = as_path(path, error=OutputError)
    return write_json(path, truth_json(truth))


def friction_torque(dq: np.ndarray, coulomb, viscous) -> np.ndarray:
    """The regressor's friction ``fc·sign(dq) + fv·dq`` [N·m] for velocities ``dq`` (N, nv)."""
    dq = as_floats(array_like(dq, "dq"), "dq")
    nv = dq.shape[-1] if dq.ndim else 1
    fc, fv = as_floats(coulomb, "coulomb"), as_floats(viscous, "viscous")
    for name, v in (("coulomb", fc), ("viscous", fv)):
        if v.shape not in ((), (nv,)):
            raise DataError(f"{name}: shape {v.shape}, expected ({nv},) per joint, as the columns of dq")
    return fc * np.sign(dq) + fv * dq


#: Old public names (the seed papers' numbers) and their new ones; they still work for one release.
_DEPRECATED = {"SEED000_TABLE1": "ZHA2019_TABLE1", "seed000_trajectory": "zha2019_trajectory"}


def __getattr__(name: str):
    if name in _DEPRECATED:
        warnings.warn(
            f"pinid.simulation.twin.{name} is deprecated, use {_DEPRECATED[name]}", DeprecationWarning, stacklevel=2
        )
        return globals()[_DEPRECATED[name]]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
