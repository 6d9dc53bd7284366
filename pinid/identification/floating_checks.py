"""What a floating-base identification can be trusted for (docs/floating-base.md, "Numbers you can trust"),
beyond the σ and condition number every identification has: the one-line warnings naming the base parameters
the data barely excite, a whole-body centre of mass far from the URDF's, joint torques whose sign looks flipped,
and motion-capture orientation noise that biases the base parameters at the default cut-off; and (issue 47) the
wrench faults that pass those: a loaded contact sensor reading zero (:func:`plate_dropouts`), plates on the wrong
feet or a centre of pressure far from its foot (:func:`foot_hints`), a gyro in deg/s or an accelerometer of
flipped sign (:func:`imu_hints`), one plate's centre of pressure offset against another's (:func:`cop_offsets`)."""

from __future__ import annotations

import warnings
from collections.abc import Mapping

import numpy as np

from pinid.errors import SpecError
from pinid.identification.plausibility import flipped_torque_signs, torque_scale

#: A base parameter is barely excited when 2σ exceeds this fraction of its natural scale (mass, mass·length,
#: mass·length² of its bodies; 1 N·m or N·m·s/rad for a joint term): its 95 % interval then spans more than
#: ±10 % of what such a parameter typically is, whatever its own value (which may be near 0).
EXCITED_FRACTION = 0.10


def flipped_floating_signs(model, samples, *, limit: int = 5000, found: dict | None = None) -> list[str]:
    """The joints whose recorded torque is anti-correlated with the URDF's for the same motion and wrenches
    (``RNEA_joints − (Σ J_cᵀ f_c)_joints`` plus the URDF's friction, on at most ``limit`` samples of the
    prepared training recordings ``samples``; samples where a foot without a measured wrench is in contact, or a
    foot's contact phase is uncertain, are left out): one DataWarning "check the sign of tau_<joint>" (:func:`pinid.identification.plausibility.
    flipped_torque_signs`, the fixed base's check).  The torques' scale against the same torque is checked too
    (:func:`~pinid.identification.plausibility.torque_scale`); ``found`` (a dict), when given, gets it under
    ``"torque_scale"``."""
    from pinid.model.floating import BASE_NV

    if not hasattr(model, "ff_model") or isinstance(samples, (str, bytes)) or not hasattr(samples, "__iter__"):
        raise SpecError("flipped_floating_signs: expected a FloatingRobotModel and a list of FloatingSamples")
    samples = [s for s in samples if s.data.tau is not None]
    total = sum(s.n for s in samples)
    if not total:
        return []
    step = max(1, total // limit)
    recorded, nominal = [], []
    for s in samples:
        kept = _measured_rows(model, s, step)
        if kept is None:
            continue
        k, _, _, dq, r = kept
        nominal.append(r[:, BASE_NV:] + model.coulomb * np.sign(dq) + model.viscous * dq)
        recorded.append(s.data.tau[k])
    if not recorded:
        return []
    recorded, nominal = np.concatenate(recorded), np.concatenate(nominal)
    ratio = torque_scale(model.joint_names, recorded, nominal, ", ".join(s.source for s in samples))
    if isinstance(found, dict):
        found["torque_scale"] = ratio
    return flipped_torque_signs(model.joint_names, recorded, nominal)


#: The whole-body centre of mass (identified first moments / mass, base frame) is implausible when it is this
#: fraction of the robot's size (the farthest body origin from the base link's, at the mean training posture)
#: or more from the URDF's: a few centimetres on a lower-body exoskeleton, far beyond what noise moves it.
COM_WARNED = 0.10


def total_mass_combination(base) -> np.ndarray | None:
    """(nb,) the combination c of the base parameters that is the total mass, ``Σ mᵢ = cᵀ·x`` (the sum of every
    body's ``.m`` standard parameter, in the row space of the base map ``P``); None when the rows used do not
    determine the total mass (a fixed base, the joint rows alone).  On a floating base with the base rows the QR
    may lead the mass group with any body's mass (``torso_roll.mR`` on the iCub), so its name does not say it."""
    names = list(getattr(base, "standard_names", []))
    e = np.array([n.endswith(".m") for n in names], dtype=float)
    if not e.any():
        return None
    P = np.asarray(base.P, dtype=float)
    c = np.linalg.lstsq(P.T, e, rcond=None)[0]
    if np.linalg.norm(P.T @ c - e) > 1e-8 * np.linalg.norm(e):
        return None
    return np.where(np.abs(c) < 1e-12, 0.0, c)


def first_moments_map(model, terms, base, q: np.ndarray) -> np.ndarray:
    """(3, nb): the whole-body first moments ``h = Σ mᵢcᵢ = L·x`` [kg·m] of base parameters x, in the base frame
    at joint positions ``q`` (nv,): read from the moment rows of the base at rest in three base orientations
    (``moment = g_b × h``, g in the base frame), by least squares."""
    import pinocchio as pin

    from pinid.model.regressor import regressor

    if not hasattr(model, "ff_model") or not hasattr(base, "independent"):
        raise SpecError("whole_body_com: expected a FloatingRobotModel, its terms and base parameters")
    g = np.asarray(model.ff_model.gravity.linear)
    A, Y = [], []
    zero6, zero = np.zeros((1, 6)), np.zeros((1, model.nv))
    for axis, angle in (
        (np.array([1.0, 0, 0]), 0.0),
        (np.array([1.0, 0, 0]), np.pi / 2),
        (np.array([0, 1.0, 0]), np.pi / 2),
    ):
        R = pin.exp3(axis * angle)
        quat = pin.Quaternion(R).coeffs()  # x, y, z, w
        W = regressor(model, *model.full_state(np.r_[0, 0, 0, quat][None], zero6, zero6, q[None], zero, zero), terms)
        Y.append(W[3:6][:, base.independent])
        gb = R.T @ g
        A.append(pin.skew(gb))  # the moment the base must receive to hold the robot still: g_b × h
    return np.linalg.lstsq(np.vstack(A), np.vstack(Y), rcond=None)[0]


def whole_body_com(model, terms, base, q: np.ndarray, values: np.ndarray, mass: np.ndarray | None = None) -> np.ndarray:
    """The whole-body centre of mass [m] in the base frame at joint positions ``q`` (nv,) of each base vector
    ``values`` (k, nb): the first moments ``h`` (:func:`first_moments_map`) divided by the total mass ``cᵀ·x``
    (``mass``: c, :func:`total_mass_combination`; default the first entry, ``base.mR``)."""
    values = np.atleast_2d(np.asarray(values, dtype=float))
    L = first_moments_map(model, terms, base, q)
    c = np.eye(values.shape[1])[0] if mass is None else np.asarray(mass, dtype=float)
    return (values @ L.T) / (values @ c)[:, None]


#: ... and when the offset is this many of its standard deviations or more (:func:`com_offset_std`): an offset
#: within a few σ is the centre of mass the data leave undetermined, not a wrong wrench — unless it exceeds the
#: robot's size (a centre of mass outside the robot), which is warned whatever its σ.
COM_SIGMAS = 3.0


def com_offset_std(H: np.ndarray, values: np.ndarray, std: np.ndarray, offset: np.ndarray, mass=None) -> float:
    """The standard deviation [m] of a method's whole-body centre of mass ``H @ values / m`` along its ``offset``
    from the URDF's, from the base parameters' σ ``std``, with the total mass ``m = massᵀ·values`` (``mass``: the
    combination :func:`total_mass_combination`; default the first entry, ``base.mR``), to first order
    (``J = (H − com·massᵀ) / m``).  The σ are per parameter (their correlations are not kept), so it is bounded by
    the sum ``Σ |uᵀJⱼ| σⱼ``, which holds for any correlation; NaN where a σ is not known (a metaheuristic's, an
    SDP value on a bound)."""
    values, std = np.asarray(values, dtype=float), np.asarray(std, dtype=float)
    c = np.eye(len(values))[0] if mass is None else np.asarray(mass, dtype=float)
    m = float(values @ c)
    norm = float(np.linalg.norm(offset))
    if norm == 0 or m <= 0 or std.shape != values.shape or not np.all(np.isfinite(std)):
        return float("nan")
    com = H @ values / m
    J = (H - np.outer(com, c)) / m
    return float(np.abs((offset / norm) @ J) @ std)


def com_warning(ident, model, terms, base, q: np.ndarray, source: str, hints=()) -> str | None:
    """One DataWarning line when a method's whole-body centre of mass (:func:`whole_body_com`, at the mean
    training posture ``q``) is :data:`COM_WARNED` × the robot's size or more from the URDF's, and
    :data:`COM_SIGMAS` of its σ along the offset (:func:`com_offset_std`, ``info["com_offset_std"]``) or more when
    the method has σ (or the robot's size or more, whatever the σ), naming the likely
    causes (``hints``: what the raw recordings point to, :func:`pinid.identification.floating.recording_hints`,
    named instead when given); returns it (None when every method's is plausible or the rows have no ``base.mR``)."""
    import pinocchio as pin

    from pinid.errors import DataWarning

    if not hasattr(ident, "results") or not hasattr(model, "ff_model") or not isinstance(source, str):
        raise SpecError("com_warning: expected an Identification, its FloatingRobotModel and a source name")
    mass = total_mass_combination(base)
    if mass is None or not ident.results:
        return None
    methods = list(ident.results)
    values = np.array([ident.base["nominal"]] + [ident.results[m].base for m in methods])
    if np.any(values @ mass <= 0):
        return None  # the total mass's own check says it
    H = first_moments_map(model, terms, base, np.asarray(q, dtype=float))
    com = values @ H.T / (values @ mass)[:, None]
    m, d = model.ff_model, model.ff_model.createData()
    pin.framesForwardKinematics(m, d, np.r_[0, 0, 0, 0, 0, 0, 1.0, model.configuration(q)])
    size = max(float(np.linalg.norm(f.translation)) for f in d.oMf)
    off = {k: float(np.linalg.norm(c - com[0])) for k, c in zip(methods, com[1:])}
    sigma = {}
    for k, c in zip(methods, com[1:]):
        ident.results[k].info["com"] = c.tolist()
        sigma[k] = com_offset_std(H, values[1 + methods.index(k)], ident.results[k].std, c - com[0], mass=mass)
        ident.results[k].info["com_offset_std"] = sigma[k] if np.isfinite(sigma[k]) else None
    ident.data["com_urdf"] = com[0].tolist()
    # far (COM_WARNED of the size) and known to be far (COM_SIGMAS σ): a centre of mass the data leave
    # undetermined (a suspended robot that barely tilts shows little of the height of its centre of mass)
    # is no sign of a wrong wrench, however far its value lies; one farther than the robot's size lies outside the
    # robot, which no σ makes plausible (a force plate turned by 180°: metres off, with σ as large from its misfit)
    bad = {k: v for k, v in off.items() if v >= COM_WARNED * size and (v >= size or not v < COM_SIGMAS * sigma[k])}
    if not bad:
        return None
    line = (
        f"{source}: whole-body centre of mass (base frame, mean posture) "
        + ", ".join(
            f"{k} ({', '.join(f'{x:.3g}' for x in com[1 + methods.index(k)])}) m, {v:.3g} m off" for k, v in bad.items()
        )
        + f" against the URDF's ({', '.join(f'{x:.3g}' for x in com[0])}) m; more than {COM_WARNED:.0%} of the robot's "
        f"size ({size:.3g} m): "
        + (
            "likely cause: " + "; ".join(hints)
            if hints
            else "check the wrench's axes and frame (link or world, force plate x/y), the sign of its moments and the "
            "point they are taken about (centre of pressure, sensor origin)"
        )
    )
    warnings.warn(line, DataWarning, stacklevel=3)
    return line


def excitation_warning(ident, natural_scale: np.ndarray, source: str) -> str | None:
    """One DataWarning line naming the base parameters whose 2σ exceeds :data:`EXCITED_FRACTION` of their
    natural scale (``natural_scale`` (nb,), :attr:`IdentificationProblem.natural_scale`) for the method with
    the lowest validation (else training) RMS among those with a σ; returns it, None when every one is excited."""
    if not hasattr(ident, "results") or not isinstance(source, str) or isinstance(natural_scale, (str, bytes)):
        raise SpecError("excitation_warning: expected an Identification, the natural scales and a source name")
    scale = np.asarray(natural_scale, dtype=float)
    names = list(ident.base.get("names") or [])
    have = [m for m, r in ident.results.items() if np.any(np.isfinite(r.std))]
    if not have or scale.shape != (len(names),):
        return None
    score = lambda m: (ident.results[m].validation or ident.results[m].train).headline()  # noqa: E731
    method = min(have, key=score)
    ratio = 2 * np.asarray(ident.results[method].std, dtype=float) / np.maximum(scale, 1e-300)
    bad = sorted(((n, float(v)) for n, v in zip(names, ratio) if v > EXCITED_FRACTION), key=lambda kv: -kv[1])
    ident.results[method].info["barely_excited"] = [n for n, _ in bad]
    if not bad:
        return None
    shown = ", ".join(f"{n} {100 * v:.3g} %" for n, v in bad[:4]) + (
        f" and {len(bad) - 4} more" if len(bad) > 4 else ""
    )
    line = (
        f"{source}: {method}: barely excited (2σ > {EXCITED_FRACTION:.0%} of their natural scale): {shown}; a low "
        "held-out error does not vouch for them: move those joints more (pinid excite --base floating) or record longer"
    )
    from pinid.errors import DataWarning

    warnings.warn(line, DataWarning, stacklevel=3)
    return line


#: Motion-capture orientation noise biases the base parameters when the noise it puts on the filtered base
#: angular acceleration exceeds this [rad/s²].  From the suspended twin of docs/floating-base.md (1 kHz, 0.11°
#: per axis): 0.48 rad/s² at the default 10 Hz cut-off (base.mzR +2.74 for −0.37), 0.085 at 5 Hz (+0.39),
#: 0.0086 at 2 Hz (−0.324: harmless); the threshold sits between the last two, at their geometric mean.
ORIENTATION_NOISE_WARNED = 0.03


def orientation_noise(t: np.ndarray, quat: np.ndarray, cutoff: float | None = None) -> tuple[float, float]:
    """``(σ, σ_ω̇)``: the orientation noise of a motion-capture quaternion stream ``quat`` (N, 4) ``x, y, z, w``
    at times ``t`` [s], per axis [deg] (RMS of the rotation from its low-passed copy, at ``cutoff`` [Hz],
    default the preprocessing's, to the raw sample), and the noise that white noise of that level puts on the
    angular acceleration differentiated twice after that low-pass, ``σ·(2π)²·fc^2.5·√(2/(5·fs))`` [rad/s²]."""
    from pinid.data.contacts import continuous_quat, quat_mul
    from pinid.data.preprocess import default_cutoff, default_trim, lowpass

    if isinstance(t, (str, bytes)) or isinstance(quat, (str, bytes)) or isinstance(cutoff, (str, bytes, bool)):
        raise SpecError("orientation_noise: expected times [s], (N, 4) quaternions and a cut-off [Hz] or None")
    t, quat = np.asarray(t, dtype=float), np.asarray(quat, dtype=float)
    if quat.ndim != 2 or quat.shape[1] != 4 or t.shape != (len(quat),) or len(t) < 16:
        raise SpecError("orientation_noise: expected (N, 4) quaternions at N ≥ 16 times")
    fs = 1.0 / float(np.median(np.diff(t)))
    fc = default_cutoff(fs) if cutoff is None else float(cutoff)
    q = continuous_quat(quat / np.linalg.norm(quat, axis=1, keepdims=True))
    smooth = np.column_stack([lowpass(q[:, i], fs, fc) for i in range(4)])
    smooth /= np.linalg.norm(smooth, axis=1, keepdims=True)
    r = quat_mul(smooth * np.array([-1, -1, -1, 1.0]), q)
    rotvec = 2 * r[:, :3] * np.sign(r[:, 3:] + (r[:, 3:] == 0))  # small angles
    edge = min(int(default_trim(fs, fc, 4) * fs), len(t) // 4)  # the filter's ends
    sigma = float(np.sqrt(np.mean(rotvec[edge : len(t) - edge] ** 2)))
    return float(np.degrees(sigma)), sigma * (2 * np.pi) ** 2 * fc**2.5 * np.sqrt(2 / (5 * fs))


def orientation_noise_warning(rec, preprocess, source: str) -> str | None:
    """One DataWarning line when the base orientation comes from motion capture (``rec.floating.base_pose``; an IMU's
    gyro needs one differentiation fewer), the cut-off is the default (``preprocess`` None, True, or options
    without ``cutoff`` or ``preset``) and :func:`orientation_noise` puts more than
    :data:`ORIENTATION_NOISE_WARNED` on the base angular acceleration; returns it, else None."""
    if getattr(rec, "floating", None) is None or not isinstance(source, str) or isinstance(preprocess, (str, bytes)):
        raise SpecError(
            "orientation_noise_warning: expected a Dataset with floating channels, preprocessing options and a source"
        )
    pose = rec.floating.base_pose
    if pose is None or preprocess is False:
        return None
    if isinstance(preprocess, Mapping) and (preprocess.get("cutoff") is not None or preprocess.get("preset")):
        return None
    sigma, noise = orientation_noise(rec.t, pose[:, 3:])
    if noise <= ORIENTATION_NOISE_WARNED:
        return None
    fs = 1.0 / float(np.median(np.diff(rec.t)))
    safe = (ORIENTATION_NOISE_WARNED / noise) ** 0.4 * min(10.0, fs / 10)  # σ_ω̇ ∝ fc^2.5
    line = (
        f"{source}: motion-capture orientation noise {sigma:.2g}° per axis puts {noise:.2g} rad/s² of noise on the "
        f"base angular acceleration at the default cut-off (more than {ORIENTATION_NOISE_WARNED:g}), which biases "
        f"the base parameters: give --cutoff {safe:.2g} or lower (if the excitation's band allows) or record the "
        "base with an IMU (its gyro needs one differentiation fewer)"
    )
    from pinid.errors import DataWarning

    warnings.warn(line, DataWarning, stacklevel=3)
    return line


# ------------------------------------------------------------------------------- the raw wrench channels (issue 47)
#: A measured contact force is "about zero" below this share of the robot's weight, "carrying load" above
#: :data:`LOADED`; a dropout is a stretch of at least :data:`DROPOUT_SECONDS` in contact at about zero that
#: starts or ends with a jump from or to a load (a foot's force ramps up and down over tens of milliseconds).
NEAR_ZERO = 0.05
LOADED = 0.2
DROPOUT_SECONDS = 0.02
#: A plate's centre of pressure lies this far [m] (median, horizontal) or more from the link it is under: the
#: plate's frame or units are wrong (a foot's CoP stays within its sole, some 0.1–0.3 m).
COP_FAR = 1.0
#: A gyro's angular speed this many times that of its own orientation stream (or fewer times the inverse): in
#: deg/s (×57.3).
GYRO_RATIO = 10.0
#: ... judged only when the orientation stream turns at this median angular speed [rad/s] or more.
GYRO_MOVING = 0.05


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of each run of True in ``mask`` (stop exclusive)."""
    d = np.diff(np.r_[0, mask.astype(np.int8), 0])
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def _column(rec, link: str) -> str:
    return f"plate_{link}" if link in rec.plates else f"wrench_{link}"


def plate_dropouts(ds, weight: float) -> list[str]:
    """A phrase for each link of the raw floating recording ``ds`` whose measured force (plate or wrench) reads
    about zero (< :data:`NEAR_ZERO` × ``weight`` [N]) for :data:`DROPOUT_SECONDS` or longer while its contact
    phase is 1 and the sample just before or after carries load (> :data:`LOADED` × ``weight``): the sensor
    dropped out (an amplifier disconnected, a plate zeroed mid-trial)."""
    if getattr(ds, "floating", None) is None:
        raise SpecError("plate_dropouts: expected a Dataset with floating channels")
    rec, t, out = ds.floating, np.asarray(ds.t, dtype=float), []
    fs = 1.0 / float(np.median(np.diff(t)))
    for link, phase in rec.contacts.items():
        w = rec.plates.get(link, rec.wrenches.get(link))
        if w is None:
            continue
        f = np.linalg.norm(np.asarray(w, dtype=float)[:, :3], axis=1)
        contact = np.asarray(phase, dtype=float) > 0.5
        low, loaded = contact & (f < NEAR_ZERO * weight), contact & (f > LOADED * weight)
        for a, b in _runs(low):
            if b - a < max(3, DROPOUT_SECONDS * fs):
                continue
            edge = [i for i in (a - 1, b) if 0 <= i < len(f) and loaded[i]]
            if edge:
                out.append(
                    f"{ds.source}: {_column(rec, link)} reads about 0 N (at most {f[a:b].max():.3g} N) from t = "
                    f"{t[a]:.4g} to {t[b - 1]:.4g} s while contact_{link} is 1 and the force was {f[edge[0]]:.3g} N "
                    "next to it: the sensor dropped out (amplifier disconnected, plate zeroed mid-trial); drop that "
                    "stretch (rows = [start, stop] in a mapping spec)"
                )
                break
    return out


def _link_positions(model, ds, links, limit: int = 1500) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Sample indices (at most ``limit``, evenly spaced) and each link's world position (k, 3) there, from the
    base pose and the joint positions of the raw recording ``ds``."""
    import pinocchio as pin

    rec = ds.floating
    k = np.arange(0, ds.n, max(1, ds.n // limit))
    m, d = model.ff_model, model.ff_model.createData()
    ids = {link: model.frame_id(link, "contact link") for link in links}
    pos = {link: np.empty((len(k), 3)) for link in links}
    pose = np.asarray(rec.base_pose, dtype=float)
    for i, s in enumerate(k):
        quat = pose[s, 3:] / np.linalg.norm(pose[s, 3:])
        pin.framesForwardKinematics(m, d, np.r_[pose[s, :3], quat, model.configuration(ds.q[s])])
        for link, fid in ids.items():
            pos[link][i] = d.oMf[fid].translation
    return k, pos


def foot_hints(ds, model, weight: float) -> list[str]:
    """Phrases for the plates of the raw floating recording ``ds`` (with a base pose) that do not match their
    foot: a centre of pressure a median :data:`COP_FAR` or more from the link it is under (millimetres when the
    CoP / 1000 lies near it, else the plate's frame: axes turned, origin not the world's), and links that move
    faster while their plate and contact phase say they carry the load than while they are off the ground
    (plates and contacts on the wrong feet)."""
    if getattr(ds, "floating", None) is None:
        raise SpecError("foot_hints: expected a Dataset with floating channels")
    rec = ds.floating
    links = [link for link in rec.plates if link in rec.contacts] or list(rec.plates)
    if rec.base_pose is None or not rec.plates or ds.n < 10 or not np.all(np.isfinite(rec.base_pose)):
        return []
    k, pos = _link_positions(model, ds, list(rec.plates))
    t, out = np.asarray(ds.t, dtype=float)[k], []
    for link, p in rec.plates.items():
        p = np.asarray(p, dtype=float)[k]
        loaded = np.linalg.norm(p[:, :3], axis=1) > LOADED * weight
        if loaded.sum() < 5:
            continue
        dist = np.median(np.linalg.norm(p[loaded, 3:5] - pos[link][loaded, :2], axis=1))
        if dist >= COP_FAR:
            in_mm = np.median(np.linalg.norm(p[loaded, 3:5] / 1000 - pos[link][loaded, :2], axis=1)) < COP_FAR / 2
            cause = (
                "units: the CoP in mm (m expected)"
                if in_mm
                else "the plate's frame (x/y axes turned, origin not the world's: the CoP in world coordinates "
                "expected) or the plate under another link"
            )
            out.append(
                f"{ds.source}: plate_{link}'s centre of pressure lies a median {dist:.3g} m from '{link}' while "
                f"loaded; likely cause: {cause}"
            )
    speeds, fast = {}, []
    for link in links:
        if link not in rec.contacts:
            continue
        f = np.linalg.norm(np.asarray(rec.plates[link], dtype=float)[k, :3], axis=1)
        contact = np.asarray(rec.contacts[link], dtype=float)[k] > 0.5
        loaded, free = contact & (f > LOADED * weight), ~contact
        if loaded.sum() < 10 or free.sum() < 10:
            continue
        v = np.linalg.norm(np.gradient(pos[link][:, :2], t, axis=0), axis=1)
        speeds[link] = (float(np.median(v[loaded])), float(np.median(v[free])))
        if speeds[link][0] > speeds[link][1]:
            fast.append(link)
    if fast:
        said = ", ".join(f"'{x}' {speeds[x][0]:.2g} m/s loaded, {speeds[x][1]:.2g} m/s off the ground" for x in fast)
        which = (
            f"the plates and contact phases of {' and '.join(fast)} are on the wrong feet (swapped?)"
            if len(fast) > 1
            else f"plate_{fast[0]}_* and contact_{fast[0]} belong to another foot"
        )
        out.append(
            f"{ds.source}: feet move faster while their plate carries load than in the air ({said}; a foot on the "
            f"ground stands nearly still): {which}"
        )
    return out


def imu_hints(ds) -> list[str]:
    """Phrases for the IMU of the raw floating recording ``ds``: a gyro in deg/s (its angular speed about 57 ×
    that of the IMU's own orientation stream) and an accelerometer of flipped sign (its specific force,
    turned to the world by that orientation, points down on average: an IMU at rest reads +9.81 m/s² up)."""
    from pinid.data.contacts import continuous_quat, quat_matrix, quat_mul

    if getattr(ds, "floating", None) is None:
        raise SpecError("imu_hints: expected a Dataset with floating channels")
    rec, out = ds.floating, []
    q = rec.imu.get("q")
    if q is None or ds.n < 10 or not np.all(np.isfinite(q)):
        return out
    q = continuous_quat(np.asarray(q, dtype=float) / np.linalg.norm(q, axis=1, keepdims=True))
    t = np.asarray(ds.t, dtype=float)
    if "w" in rec.imu:
        r = quat_mul(q[:-1] * np.array([-1, -1, -1, 1.0]), q[1:])  # body-frame rotation between samples
        w_q = np.linalg.norm(2 * r[:, :3] * np.sign(r[:, 3:] + (r[:, 3:] == 0)), axis=1) / np.diff(t)
        w_g = np.linalg.norm(np.asarray(rec.imu["w"], dtype=float), axis=1)
        a, b = float(np.median(w_g)), float(np.median(w_q))
        if b > GYRO_MOVING and a / b > GYRO_RATIO:  # a still robot's gyro reads its noise: no verdict
            out.append(
                f"{ds.source}: the gyro reads {a / b:.3g} × the angular speed of the IMU's orientation (median "
                f"{a:.3g} against {b:.3g} rad/s): units: the gyro in deg/s (rad/s expected)"
                if 20 < a / b < 200
                else f"{ds.source}: the gyro reads {a / b:.3g} × the angular speed of the IMU's orientation: its units"
            )
    if "a" in rec.imu:
        up = np.einsum("nij,nj->ni", quat_matrix(q), np.asarray(rec.imu["a"], dtype=float))[:, 2]
        if np.mean(up) < -0.5 * 9.81:
            out.append(
                f"{ds.source}: the accelerometer's specific force points down (mean {np.mean(up):.3g} m/s² along the "
                "world's z; an IMU reads +9.81 m/s² up at rest): its sign is flipped"
            )
    return out


#: Two force plates' centres of pressure are offset against each other when the base moments under the URDF
#: put one this far [m] from where the other's says (a foot is some 0.1 m wide; the twin gives < 1 cm).
COP_OFFSET_WARNED = 0.03


def cop_offsets(model, samples, *, limit: int = 3000) -> dict[str, np.ndarray]:
    """Each force plate's centre-of-pressure offset [m] (world x, y) against the last plate's, that best
    explains the base moments the measured wrenches leave unexplained under the URDF (``RNEA_base − Σ J_cᵀ f_c``
    on at most ``limit`` samples of the prepared recordings ``samples``): a CoP moved by δ adds the couple
    δ × F.  A common offset of every plate is the whole-body centre of mass's error, fitted alongside and
    left out (:func:`com_warning` judges it).  Empty with fewer than two plates (world-frame wrenches)."""
    import pinocchio as pin

    from pinid.data.contacts import quat_matrix

    if not hasattr(model, "ff_model") or isinstance(samples, (str, bytes)) or not hasattr(samples, "__iter__"):
        raise SpecError("cop_offsets: expected a FloatingRobotModel and a list of FloatingSamples")
    samples = list(samples)
    plates = sorted({w.link for s in samples for w in s.wrenches if w.frame == "world"})
    if len(plates) < 2 or any({w.link for w in s.wrenches if w.frame == "world"} != set(plates) for s in samples):
        return {}
    step = max(1, sum(s.n for s in samples) // limit)
    X, y = [], []
    for s in samples:
        kept = _measured_rows(model, s, step)
        if kept is None:
            continue
        _, wrenches, bq, _, r = kept
        Rt = np.transpose(quat_matrix(bq[:, 3:]), (0, 2, 1))
        force = {w.link: np.asarray(w.values)[:, :3] for w in wrenches if w.frame == "world"}
        total = sum(force.values())
        cols = [np.einsum("nij,njk->nik", Rt, np.array([pin.skew(f) for f in force[p]]))[:, :, :2] for p in plates[:-1]]
        cols.append(np.array([pin.skew(f) for f in np.einsum("nij,nj->ni", Rt, total)]))
        X.append(np.concatenate(cols, axis=2).reshape(-1, sum(c.shape[2] for c in cols)))
        y.append(r[:, 3:6].reshape(-1))
    if not X:
        return {}
    coef = np.linalg.lstsq(np.vstack(X), np.concatenate(y), rcond=None)[0]
    return {p: coef[2 * i : 2 * i + 2] for i, p in enumerate(plates[:-1])} | {"reference": plates[-1]}


def cop_offset_warning(model, samples, source: str) -> str | None:
    """One DataWarning line when a plate's centre of pressure is :data:`COP_OFFSET_WARNED` or more from where
    the base moments under the URDF put it against another plate's (:func:`cop_offsets`); returns it."""
    from pinid.errors import DataWarning

    found = cop_offsets(model, samples)
    ref = found.pop("reference", None)
    bad = {p: d for p, d in found.items() if np.linalg.norm(d) >= COP_OFFSET_WARNED}
    if not bad:
        return None
    line = (
        f"{source}: "
        + ", ".join(
            f"plate_{p}'s centre of pressure is ({d[0]:+.3g}, {d[1]:+.3g}) m (world x, y) off against plate_{ref}'s"
            for p, d in bad.items()
        )
        + " by the base's moments under the URDF (more than "
        f"{COP_OFFSET_WARNED:g} m): one plate's CoP is offset (its origin, or copx/copy calibration); the fit "
        "would blame the joints' friction and inertia for it"
    )
    warnings.warn(line, DataWarning, stacklevel=3)
    return line


def _measured_rows(model, s, step: int):
    """Every ``step``-th sample of the prepared recording ``s`` outside a contact without a measured wrench or of
    uncertain phase: ``(k, its wrenches, base_q, dq, rnea − Σ Jᵀf)`` (the last (len(k)·nv) rows, base first [N,
    N·m]); None when no sample is left."""
    from pinid.model.floating import contact_forces, floating_rnea

    k = np.arange(0, s.n, step)
    for contact in [*s.unsensed.values(), *getattr(s, "uncertain", {}).values()]:
        k = k[~np.asarray(contact, bool)[k]]
    if not len(k):
        return None
    wrenches = [type(w)(w.link, np.asarray(w.values)[k], w.frame) for w in s.wrenches]
    bq, q, dq = s.base_q[k], s.data.q[k], s.data.dq[k]
    r = floating_rnea(model, bq, s.base_v[k], s.base_a[k], q, dq, s.data.ddq[k])
    return k, wrenches, bq, dq, (r - contact_forces(model, bq, q, wrenches) if wrenches else r)
