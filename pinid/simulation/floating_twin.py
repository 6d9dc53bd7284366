"""The floating-base twin: an exoskeleton suspended in a harness, or walking with its feet on force plates.

**Suspended** (:func:`simulate_suspended`).  The joints follow a trajectory exactly (prescribed ``q, dq, ddq``,
e.g. an excitation from ``pinid excite``); the base link hangs on a harness: a spring–damper from a fixed
anchor in the world to a point on the base link (force ``−k·(p − anchor) − c·ṗ``, world frame) plus a
rotational spring–damper that keeps the pelvis upright (moment ``−k_r·log(R) − c_r·ω``, base frame).  The
base's free motion under gravity, the harness and the legs' reaction is integrated (RK4 on Pinocchio's
free-flyer dynamics with the joint accelerations prescribed: ``a_b = M_bb⁻¹(Fh_b − h_b − M_bj·ddq)``); each
recorded sample's base acceleration is that of its own state, so every sample satisfies the equations of
motion exactly, whatever the integration error.  The harness wrench is recorded as a load cell would,
``wrench_<base link>_*`` (base frame, moment about its origin).  Joint torques are the inverse dynamics
plus the URDF's Coulomb and viscous friction.

**Gait** (:func:`simulate_gait`).  A prescribed, periodic walking pattern (documented in
docs/floating-base.md): the pelvis moves forward at a constant speed with a vertical bob twice per stride and
a lateral sway once per stride; hips, knees and ankles follow smooth sagittal gait curves, the hip
abduction a small sway; the right leg half a stride behind the left.  The motion is kinematic only: the feet
are not held still by inverse kinematics (the equations below do not need it).  Each foot is in contact
(``contact_<sole>``) during 60 % of the stride, so both are in double support for 10 % twice per stride.
By inverse dynamics the total external wrench the motion needs is the free-flyer RNEA's 6 base rows; in single
support the stance foot carries all of it; in double support it is shared with a weight that moves linearly
(smoothstep) from the trailing to the leading foot: ``f_lead = α·X_leadᵀ⁻¹ F``, ``f_trail = (1 − α)·X_trailᵀ⁻¹ F``.
Joint torques: ``τ = RNEA_joints − Σ (J_cᵀ f_c)_joints`` plus friction.  The ground reaction is recorded as
force plates under the soles (``plate_<sole>_*``: force, centre of pressure, free moment, world frame).

Noise (``noise``, standard deviations): joint positions [rad], joint torques [N·m], wrenches [N, N·m], and
the IMU's gyro [rad/s] and accelerometer [m/s²].  The IMU (``imu_frame``) is written with its orientation,
angular velocity and specific force in its frame; the base pose as motion capture (``base_*``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from pinid.data.contacts import FloatingSamples, matrix_quat
from pinid.data.dataset import Dataset, FloatingChannels
from pinid.checks import of_type
from pinid.errors import SpecError
from pinid.excitation.trajectory import FourierTrajectory
from pinid.model.floating import BASE_NV, FloatingRobotModel, Wrench, as_floating, contact_forces, floating_rnea


@dataclass(frozen=True)
class Harness:
    """A harness: anchor [m] in the world, attachment point [m] on the base link, linear stiffness [N/m] and
    damping [N·s/m], rotational stiffness [N·m/rad] and damping [N·m·s/rad]."""

    anchor: tuple[float, float, float] = (0.0, 0.0, 1.2)
    attach: tuple[float, float, float] = (0.0, 0.0, 0.15)
    stiffness: float = 20000.0
    damping: float = 1500.0
    rot_stiffness: float = 400.0
    rot_damping: float = 40.0


@dataclass(frozen=True)
class Noise:
    """Sensor noise (standard deviations): joint positions [rad], torques [N·m], wrench forces [N] and moments
    [N·m], gyro [rad/s], accelerometer [m/s²]."""

    position: float = 0.0
    torque: float = 0.0
    force: float = 0.0
    moment: float = 0.0
    gyro: float = 0.0
    accel: float = 0.0
    torque_percent: float | None = None  # when given: torque noise this % of each joint's peak torque instead


@dataclass(frozen=True)
class BaseSensors:
    """What a floating-base rig measures and how often, the floating twin's options: ``sensors=`` of
    :func:`pinid.simulation.twin.simulate` and ``floating=`` of :func:`pinid.simulation.run.simulate_and_write`.
    The sensors' ``noise`` (:class:`Noise`); with ``imu_frame``, an IMU in that URDF frame instead of motion
    capture of the base; the sample ``rate`` [Hz] (None: ``simulate``'s ``rates``, their sample rate, else
    their control rate, 1 kHz by default; a rate given there too is refused)."""

    noise: Noise = field(default_factory=Noise)
    imu_frame: str | None = None
    rate: float | None = None

    def __post_init__(self) -> None:
        of_type(self.noise, Noise, "BaseSensors noise", "a Noise", none=False)
        of_type(self.imu_frame, str, "BaseSensors imu_frame", "a link's name or None")
        of_type(self.rate, (int, float), "BaseSensors rate", "a rate [Hz] or None")


@dataclass
class TwinRun:
    """A floating-base twin run, what :func:`pinid.simulation.twin.simulate` returns for a floating model: the
    exact samples (``exact``, for noise-free identification and as the truth), the recording with noise
    (``recording``, a Dataset with its floating channels, what would be written) and the truth (``truth``, plain dict).  It unpacks as the fixed-base
    run's ``(recording, truth)`` pair: ``rec, truth = simulate(model, ...)`` reads either kind of model."""

    exact: FloatingSamples
    recording: Dataset
    truth: dict = field(default_factory=dict)

    def __iter__(self):
        return iter((self.recording, self.truth))


def _rk4_hold(model, t, traj, harness, base0):
    """Integrate the suspended base at step ``dt`` over the times ``t`` (uniform); return base q, v, a."""
    m, d = model.ff_model, model.ff_model.createData()
    nv = model.nv
    anchor, attach = np.array(harness.anchor), np.array(harness.attach)
    q_j, dq_j, ddq_j = traj

    def harness_wrench(qb, vb):
        R = pin.Quaternion(qb[6], qb[3], qb[4], qb[5]).toRotationMatrix()
        p_att = qb[:3] + R @ attach
        v_lin, w = vb[:3], vb[3:]
        v_att = R @ (v_lin + np.cross(w, attach))
        F = -harness.stiffness * (p_att - anchor) - harness.damping * v_att  # world
        f_local = R.T @ F
        moment = np.cross(attach, f_local) - harness.rot_stiffness * pin.log3(R) - harness.rot_damping * w
        return np.r_[f_local, moment]

    def accel(k_state, k):
        qb, vb = k_state
        qf = np.r_[qb, q_j[k]]
        vf = np.r_[vb, dq_j[k]]
        M = pin.crba(m, d, qf)
        M = np.triu(M) + np.triu(M, 1).T
        h = pin.nonLinearEffects(m, d, qf, vf)
        fh = harness_wrench(qb, vb)
        return np.linalg.solve(M[:BASE_NV, :BASE_NV], fh - h[:BASE_NV] - M[:BASE_NV, BASE_NV:] @ ddq_j[k]), fh

    def integrate(qb, dv):
        return pin.integrate(m, np.r_[qb, q_j[0]], np.r_[dv, np.zeros(nv)])[:7]

    n = len(t)
    dt = float(t[1] - t[0])
    Qb, Vb, Ab, Fh = np.empty((n, 7)), np.empty((n, 6)), np.empty((n, 6)), np.empty((n, 6))
    qb, vb = base0, np.zeros(6)
    for k in range(n):
        a, fh = accel((qb, vb), k)
        Qb[k], Vb[k], Ab[k], Fh[k] = qb, vb, a, fh
        if k == n - 1:
            break
        # RK4 with the joint state held at sample k for the half steps (its change is prescribed, not integrated)
        k1v, k1a = vb, a
        q2 = integrate(qb, 0.5 * dt * k1v)
        v2 = vb + 0.5 * dt * k1a
        k2a = accel((q2, v2), k)[0]
        q3 = integrate(qb, 0.5 * dt * v2)
        v3 = vb + 0.5 * dt * k2a
        k3a = accel((q3, v3), k)[0]
        q4 = integrate(qb, dt * v3)
        v4 = vb + dt * k3a
        k4a = accel((q4, v4), k + 1)[0]
        qb = integrate(qb, dt / 6 * (k1v + 2 * v2 + 2 * v3 + v4))
        qb[3:] /= np.linalg.norm(qb[3:])
        vb = vb + dt / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)
    return Qb, Vb, Ab, Fh


def _friction(model, dq):
    return model.coulomb * np.sign(dq) + model.viscous * dq


def simulate_suspended(
    model: FloatingRobotModel,
    trajectory: FourierTrajectory,
    *,
    seconds: float = 10.0,
    rate: float = 1000.0,
    harness: Harness = Harness(),
    noise: Noise = Noise(),
    seed: int = 0,
    imu_frame: str | None = None,
) -> TwinRun:
    """The exoskeleton in a harness, its joints following ``trajectory`` (see the module text)."""
    model = as_floating(model)
    t = _times(seconds, rate)
    traj = trajectory.for_joints(model.joint_names, model.name).evaluate(t)
    q_j, dq_j, ddq_j = (np.asarray(x) for x in traj)
    qb0 = np.r_[np.array(harness.anchor) - np.array(harness.attach), 0, 0, 0, 1.0]
    # start where the harness carries the robot's weight (static sag)
    mass = sum(i.mass for i in model.ff_model.inertias)
    qb0[2] -= mass * 9.81 / harness.stiffness
    Qb, Vb, Ab, Fh = _rk4_hold(model, t, (q_j, dq_j, ddq_j), harness, qb0)
    wrenches = [Wrench(model.base_link, Fh, "local")]
    rnea = floating_rnea(model, Qb, Vb, Ab, q_j, dq_j, ddq_j)
    tau = rnea[:, BASE_NV:] - contact_forces(model, Qb, q_j, wrenches)[:, BASE_NV:] + _friction(model, dq_j)
    exact = FloatingSamples(
        Dataset(t, q_j, model.joint_names, dq=dq_j, ddq=ddq_j, tau=tau, source="suspended twin"), Qb, Vb, Ab, wrenches
    )
    rec = _recording(model, exact, noise, seed, imu_frame, plates=False)
    truth = _truth(model, "suspended", seconds, rate, noise, seed, exact)
    truth["harness"] = harness.__dict__ | {"anchor": list(harness.anchor), "attach": list(harness.attach)}
    return TwinRun(exact, rec, truth)


def _times(seconds: float, rate: float) -> np.ndarray:
    if not (np.isfinite(seconds) and seconds > 0 and np.isfinite(rate) and rate > 0):
        raise SpecError(f"seconds={seconds!r}, rate={rate!r}: expected durations and rates > 0")
    n = int(round(seconds * rate)) + 1
    if n < 20:
        raise SpecError(f"seconds={seconds:g} at {rate:g} Hz: {n} samples, expected at least 20")
    return np.arange(n) / rate


# ------------------------------------------------------------------------------------------------- gait
#: The gait pattern: stride period [s], walking speed [m/s], stance fraction, pelvis height [m], bob [m] and sway [m].
GAIT = {"period": 1.1, "speed": 1.0, "stance": 0.6, "height": 0.88, "bob": 0.02, "sway": 0.03}


def _smooth(x):
    """Smoothstep 3x² − 2x³ on [0, 1]."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3 - 2 * x)


#: Gait curves of one leg over the stride phase (0 = its heel strike), rows hip abduction, hip flexion, knee,
#: ankle [rad]: constant, then cosine and sine coefficients of harmonics 1 and 2 (shapes of typical sagittal gait
#: curves; the knee stays between about 0.2 and 1.1 rad, inside its limits).
LEG_CURVES = (
    np.array([0.0, 0.15, 0.6, 0.0]),
    np.array([[0.0, 0.0], [0.35, 0.0], [-0.3, -0.1], [0.05, 0.0]]),
    np.array([[0.05, 0.0], [0.0, 0.05], [-0.25, 0.05], [0.05, -0.12]]),
)
#: Pelvis rotation amplitudes [rad]: roll (obliquity, twice per stride), pitch (tilt, twice), yaw (once).
PELVIS_ROTATION = (0.04, 0.03, 0.06)


def _leg(phase_rate: float, t: np.ndarray, shift: float):
    """(q, dq, ddq) (N, 4) of one leg at times ``t`` with its stride phase ``phase_rate·t + shift`` [cycles]."""
    c0, C, S = LEG_CURVES
    k = np.arange(1, C.shape[1] + 1)
    w = 2 * np.pi * phase_rate
    arg = 2 * np.pi * (phase_rate * t[:, None] + shift) * k  # (N, K)
    cos, sin = np.cos(arg), np.sin(arg)
    q = c0 + cos @ C.T + sin @ S.T
    dq = (-sin * k * w) @ C.T + (cos * k * w) @ S.T
    ddq = (-cos * (k * w) ** 2) @ C.T + (-sin * (k * w) ** 2) @ S.T
    return q, dq, ddq


def _euler_zyx(t: np.ndarray, w: float):
    """Pelvis orientation R = Rz(ψ)·Ry(θ)·Rx(φ) with φ, θ at twice and ψ at once the stride frequency ``w``
    [rad/s]; returns R (N, 3, 3), ω and ω̇ in the base frame (analytic)."""
    a_r, a_p, a_y = PELVIS_ROTATION
    phi, dphi, ddphi = a_r * np.sin(2 * w * t), 2 * w * a_r * np.cos(2 * w * t), -4 * w * w * a_r * np.sin(2 * w * t)
    th, dth, ddth = a_p * np.cos(2 * w * t), -2 * w * a_p * np.sin(2 * w * t), -4 * w * w * a_p * np.cos(2 * w * t)
    ps, dps, ddps = a_y * np.sin(w * t), w * a_y * np.cos(w * t), -w * w * a_y * np.sin(w * t)
    sf, cf, st, ct, sp, cp = np.sin(phi), np.cos(phi), np.sin(th), np.cos(th), np.sin(ps), np.cos(ps)
    R = np.empty((len(t), 3, 3))
    R[:, 0] = np.column_stack([cp * ct, cp * st * sf - sp * cf, cp * st * cf + sp * sf])
    R[:, 1] = np.column_stack([sp * ct, sp * st * sf + cp * cf, sp * st * cf - cp * sf])
    R[:, 2] = np.column_stack([-st, ct * sf, ct * cf])
    omega = np.column_stack([dphi - dps * st, dth * cf + dps * ct * sf, -dth * sf + dps * ct * cf])
    domega = np.column_stack(
        [
            ddphi - ddps * st - dps * dth * ct,
            ddth * cf - dth * dphi * sf + ddps * ct * sf - dps * dth * st * sf + dps * dphi * ct * cf,
            -ddth * sf - dth * dphi * cf + ddps * ct * cf - dps * dth * st * cf - dps * dphi * ct * sf,
        ]
    )
    return R, omega, domega


def gait_motion(model: FloatingRobotModel, t: np.ndarray, pattern: dict | None = None):
    """The prescribed gait: base q, v (base frame), a; joint q, dq, ddq; contact flags of the two soles; the
    stride phase."""
    p = {**GAIT, **(pattern or {})}
    T = p["period"]
    if model.nv != 8:
        raise SpecError(
            f"{model.name}: the gait pattern is for a pelvis and two 4-joint legs (8 joints), not {model.nv}"
        )
    left, right = _leg(1 / T, t, 0.0), _leg(1 / T, t, 0.5)
    q, dq, ddq = (np.hstack([a, b]) for a, b in zip(left, right))
    w = 2 * np.pi / T
    pos = np.column_stack([p["speed"] * t, p["sway"] * np.sin(w * t), p["height"] + p["bob"] * np.cos(2 * w * t)])
    vel = np.column_stack(
        [np.full_like(t, p["speed"]), p["sway"] * w * np.cos(w * t), -2 * w * p["bob"] * np.sin(2 * w * t)]
    )
    acc = np.column_stack([0 * t, -p["sway"] * w * w * np.sin(w * t), -4 * w * w * p["bob"] * np.cos(2 * w * t)])
    R, omega, domega = _euler_zyx(t, w)
    base_q = np.hstack([pos, matrix_quat(R)])
    v_local = np.einsum("nji,nj->ni", R, vel)
    a_local = np.einsum("nji,nj->ni", R, acc) - np.cross(omega, v_local)  # spatial: d/dt of v_local
    base_v = np.hstack([v_local, omega])
    base_a = np.hstack([a_local, domega])
    ph = (t / T) % 1.0
    in_left = ph < p["stance"]
    in_right = ((ph + 0.5) % 1.0) < p["stance"]
    return (base_q, base_v, base_a, q, dq, ddq), (in_left, in_right), ph


def simulate_gait(
    model: FloatingRobotModel,
    *,
    seconds: float = 10.0,
    rate: float = 1000.0,
    noise: Noise = Noise(),
    seed: int = 0,
    soles: tuple[str, str] = ("l_sole", "r_sole"),
    imu_frame: str | None = None,
    pattern: dict | None = None,
) -> TwinRun:
    """The exoskeleton walking (see the module text): ground reaction on the soles, torques by inverse dynamics.
    The base motion is recorded as motion capture: ``imu_frame`` is refused, since force plates need the base
    position in the world, which an IMU does not give (pinid identify would refuse the recording)."""
    model = as_floating(model)
    if imu_frame is not None:
        raise SpecError(
            f"IMU frame '{imu_frame}' with the gait: its force plates need the base position in the world "
            "(motion capture), which an IMU alone does not give, so pinid identify would refuse the recording; "
            "leave the IMU out (--imu) for the gait, or use it with a trajectory (the harness)"
        )
    t = _times(seconds, rate)
    states, (left, right), ph = gait_motion(model, t, pattern)
    base_q, base_v, base_a, q, dq, ddq = states
    rnea = floating_rnea(model, *states)
    m, d = model.ff_model, model.ff_model.createData()
    ids = [model.frame_id(s, "sole") for s in soles]
    stance = GAIT["stance"] if pattern is None else {**GAIT, **pattern}["stance"]
    # weight of the left foot: 1 in its single support, 0 in the right's, moving linearly in double support
    ds = stance - 0.5  # length of each double support (fraction of the stride)
    alpha = np.where(left & ~right, 1.0, np.where(right & ~left, 0.0, 0.0))
    in_ds1 = (ph >= 0) & (ph < ds)  # left heel strike: weight moves right -> left
    in_ds2 = (ph >= 0.5) & (ph < 0.5 + ds)  # right heel strike: left -> right
    alpha = np.where(in_ds1, _smooth(ph / ds), alpha)
    alpha = np.where(in_ds2, 1 - _smooth((ph - 0.5) / ds), alpha)
    fl, fr = np.zeros((len(t), 6)), np.zeros((len(t), 6))
    for k in range(len(t)):
        qf = np.r_[base_q[k], q[k]]
        pin.computeJointJacobians(m, d, qf)
        pin.updateFramePlacements(m, d)
        Jl = pin.getFrameJacobian(m, d, ids[0], pin.WORLD)[:, :BASE_NV]
        Jr = pin.getFrameJacobian(m, d, ids[1], pin.WORLD)[:, :BASE_NV]
        F = rnea[k, :BASE_NV]
        if alpha[k] > 0:
            fl[k] = alpha[k] * np.linalg.solve(Jl.T, F)
        if alpha[k] < 1:
            fr[k] = (1 - alpha[k]) * np.linalg.solve(Jr.T, F)
    wrenches = [Wrench(soles[0], fl, "world"), Wrench(soles[1], fr, "world")]
    tau = rnea[:, BASE_NV:] - contact_forces(model, base_q, q, wrenches)[:, BASE_NV:] + _friction(model, dq)
    exact = FloatingSamples(
        Dataset(t, q, model.joint_names, dq=dq, ddq=ddq, tau=tau, source="gait twin"), base_q, base_v, base_a, wrenches
    )
    contacts = {soles[0]: alpha > 0, soles[1]: alpha < 1}
    rec = _recording(model, exact, noise, seed, imu_frame, plates=True, contacts=contacts)
    truth = _truth(model, "gait", seconds, rate, noise, seed, exact)
    truth["gait"] = {**GAIT, **(pattern or {})}
    return TwinRun(exact, rec, truth)


# ------------------------------------------------------------------------------------------------- recording
def _recording(model, s: FloatingSamples, noise: Noise, seed: int, imu_frame, *, plates: bool, contacts=None):
    """The noisy recording of exact samples: joints, motion capture or IMU, load cells or force plates."""
    rng = np.random.default_rng(seed)
    n, ds = s.n, s.data
    sigma = np.asarray(noise.torque, dtype=float)
    if noise.torque_percent is not None:
        sigma = noise.torque_percent / 100 * np.abs(ds.tau).max(axis=0)
    q = ds.q + noise.position * rng.standard_normal(ds.q.shape)
    tau = ds.tau + sigma * rng.standard_normal(ds.tau.shape)
    rec = FloatingChannels(model=model)
    if imu_frame is None:
        rec.base_pose = s.base_q.copy()
    else:
        frame = model.ff_model.frames[model.frame_id(imu_frame, "IMU frame")]
        if frame.parentJoint != 1:
            raise SpecError(f"IMU frame '{imu_frame}' is not fixed to the base link '{model.base_link}'")
        R_bi, r = frame.placement.rotation, frame.placement.translation
        Rb = np.array([pin.Quaternion(x[6], x[3], x[4], x[5]).toRotationMatrix() for x in s.base_q])
        v, w = s.base_v[:, :3], s.base_v[:, 3:]
        a, dw = s.base_a[:, :3], s.base_a[:, 3:]
        a_o = a + np.cross(w, v)  # classical acceleration of the base origin, base frame
        a_i = a_o + np.cross(dw, r) + np.cross(w, np.cross(w, r))
        g = np.asarray(model.ff_model.gravity.linear)
        spec_b = a_i - np.einsum("nji,j->ni", Rb, g)
        rec.imu_frame = imu_frame
        rec.imu = {
            "q": matrix_quat(Rb @ R_bi),
            "w": w @ R_bi + noise.gyro * rng.standard_normal((n, 3)),
            "a": spec_b @ R_bi + noise.accel * rng.standard_normal((n, 3)),
        }
    scale = np.r_[np.full(3, noise.force), np.full(3, noise.moment)]
    for wr in s.wrenches:
        noisy = wr.values + scale * rng.standard_normal((n, 6))
        if contacts is not None:
            noisy = np.where(contacts[wr.link][:, None], noisy, 0.0)
        if wr.frame == "local":
            rec.wrenches[wr.link] = noisy
        elif plates:
            rec.plates[wr.link] = _plate(noisy, model, s, wr.link)
        if contacts is not None:
            rec.contacts[wr.link] = contacts[wr.link]
    return Dataset(ds.t, q, ds.joints, tau=tau, source=ds.source, floating=rec)


def _plate(w: np.ndarray, model, s: FloatingSamples, link: str) -> np.ndarray:
    """Force-plate columns (fx fy fz copx copy copz tz) of a world wrench about the origin; the centre of pressure
    on the plane at the sole's height; zeros where there is no vertical force."""
    m, d = model.ff_model, model.ff_model.createData()
    fid = model.frame_id(link)
    out = np.zeros((len(w), 7))
    for k in range(len(w)):
        F, n = w[k, :3], w[k, 3:]
        if F[2] <= 1e-9:
            continue
        pin.framesForwardKinematics(m, d, np.r_[s.base_q[k], s.data.q[k]])
        cz = d.oMf[fid].translation[2]
        cx = (cz * F[0] - n[1]) / F[2]
        cy = (n[0] + cz * F[1]) / F[2]
        tz = n[2] - (cx * F[1] - cy * F[0])
        out[k] = [*F, cx, cy, cz, tz]
    return out


def _truth(model, kind, seconds, rate, noise, seed, exact: FloatingSamples) -> dict:
    """The run's truth, JSON-ready but for ``"signals"``: the exact joint signals (``exact.data``; the fixed
    twin's truth carries its own the same way, :func:`pinid.simulation.twin.truth_json` leaves them out)."""
    from pinid.model.regressor import parameter_names, standard_parameters

    return {
        "kind": kind,
        "robot": model.name,
        "base": "floating",
        "base_link": model.base_link,
        "seconds": seconds,
        "rate_hz": rate,
        "seed": seed,
        "noise": {k: np.asarray(v).tolist() for k, v in noise.__dict__.items()},
        "standard_names": parameter_names(model),
        "standard": standard_parameters(model).tolist(),
        "signals": exact.data,
    }


# ------------------------------------------------------------------------------------------------- the command
def simulate_free_flyer(
    model: FloatingRobotModel, excitation, seconds: float, seed: int, rates, sensors, options: dict
) -> TwinRun:
    """The floating branch of :func:`pinid.simulation.twin.simulate` (call that): ``excitation`` "gait" walks
    (:func:`simulate_gait`); a trajectory (or its path, name or preset) the suspended legs follow
    (:func:`simulate_suspended`).  ``options``: the other keywords, ``noise`` and ``imu_frame`` (when ``sensors``
    is None), ``control_rate`` and ``sample_rate`` (over ``rates``'; not with ``sensors.rate``), and the
    fixed-base ones (not None: refused)."""
    if (rates is not None and rates.integration is not None) or options.get("integration_rate") is not None:
        raise SpecError("integration rate: for a fixed-base model only (the floating twin samples its motion)")
    options.pop("integration_rate", None)
    clock = {"control": 1000.0, "sample": None} | ({"control": rates.control, "sample": rates.sample} if rates else {})
    given = {k[:-5]: options.pop(k) for k in ("control_rate", "sample_rate") if k in options}
    clock |= given
    rate = clock["sample"] or clock["control"]
    if isinstance(sensors, BaseSensors) and sensors.rate is not None:
        if rates is not None or given:
            raise SpecError(f"sensors rate {sensors.rate:g} Hz: a second rate in rates or *_rate=, expected one")
        rate = sensors.rate
    wrong = [k for k, v in options.items() if k not in ("noise", "imu_frame") and v is not None]
    if wrong:
        raise SpecError(f"{wrong[0]}: for a fixed-base model only, {model.name} has a floating base")
    if sensors is None:
        sensors = BaseSensors(**{k: options[k] for k in ("noise", "imu_frame") if k in options})
    elif not isinstance(sensors, BaseSensors) or "noise" in options or "imu_frame" in options:
        raise SpecError(
            f"sensors: got {type(sensors).__name__}, expected BaseSensors (or noise=, imu_frame=) for a floating model"
        )
    kw = {"seconds": seconds, "rate": rate, "noise": sensors.noise, "seed": seed, "imu_frame": sensors.imu_frame}
    if isinstance(excitation, str) and excitation == "gait":
        return simulate_gait(model, **kw)
    if isinstance(excitation, str):
        from pinid.simulation.trajectories import load_trajectory

        excitation = load_trajectory(excitation, model)
    return simulate_suspended(model, excitation, **kw)
