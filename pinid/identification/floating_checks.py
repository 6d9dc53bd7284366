"""What a floating-base identification can be trusted for (docs/floating-base.md, "Numbers you can trust"),
beyond the σ and condition number every identification has: the one-line warnings naming the base parameters
the data barely excite, a whole-body centre of mass far from the URDF's, joint torques whose sign looks flipped,
and motion-capture orientation noise that biases the base parameters at the default cut-off."""

from __future__ import annotations

import warnings
from collections.abc import Mapping

import numpy as np

from pinid.errors import SpecError
from pinid.identification.plausibility import flipped_torque_signs

#: A base parameter is barely excited when 2σ exceeds this fraction of its natural scale (mass, mass·length,
#: mass·length² of its bodies; 1 N·m or N·m·s/rad for a joint term): its 95 % interval then spans more than
#: ±10 % of what such a parameter typically is, whatever its own value (which may be near 0).
EXCITED_FRACTION = 0.10


def flipped_floating_signs(model, samples, *, limit: int = 5000) -> list[str]:
    """The joints whose recorded torque is anti-correlated with the URDF's for the same motion and wrenches
    (``RNEA_joints − (Σ J_cᵀ f_c)_joints`` plus the URDF's friction, on at most ``limit`` samples of the
    prepared training recordings ``samples``; samples where a foot without a measured wrench is in contact, or a
    foot's contact phase is uncertain, are left out): one DataWarning "check the sign of tau_<joint>" (:func:`pinid.identification.plausibility.
    flipped_torque_signs`, the fixed base's check)."""
    from pinid.model.floating import BASE_NV, contact_forces, floating_rnea

    if not hasattr(model, "ff_model") or isinstance(samples, (str, bytes)) or not hasattr(samples, "__iter__"):
        raise SpecError("flipped_floating_signs: expected a FloatingRobotModel and a list of FloatingSamples")
    samples = [s for s in samples if s.data.tau is not None]
    total = sum(s.n for s in samples)
    if not total:
        return []
    step = max(1, total // limit)
    recorded, nominal = [], []
    for s in samples:
        k = np.arange(0, s.n, step)
        for contact in [*s.unsensed.values(), *getattr(s, "uncertain", {}).values()]:
            k = k[~np.asarray(contact, bool)[k]]
        if not len(k):
            continue
        wrenches = [type(w)(w.link, np.asarray(w.values)[k], w.frame) for w in s.wrenches]
        bq, q, dq = s.base_q[k], s.data.q[k], s.data.dq[k]
        rnea = floating_rnea(model, bq, s.base_v[k], s.base_a[k], q, dq, s.data.ddq[k])[:, BASE_NV:]
        ext = contact_forces(model, bq, q, wrenches)[:, BASE_NV:] if wrenches else 0.0
        nominal.append(rnea - ext + model.coulomb * np.sign(dq) + model.viscous * dq)
        recorded.append(s.data.tau[k])
    if not recorded:
        return []
    return flipped_torque_signs(model.joint_names, np.concatenate(recorded), np.concatenate(nominal))


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


def com_warning(ident, model, terms, base, q: np.ndarray, source: str) -> str | None:
    """One DataWarning line when a method's whole-body centre of mass (:func:`whole_body_com`, at the mean
    training posture ``q``) is :data:`COM_WARNED` × the robot's size or more from the URDF's, naming the likely
    causes; returns it (None when every method's is plausible or the rows have no ``base.mR``)."""
    import pinocchio as pin

    from pinid.errors import DataWarning

    if not hasattr(ident, "results") or not hasattr(model, "ff_model") or not isinstance(source, str):
        raise SpecError("com_warning: expected an Identification, its FloatingRobotModel and a source name")
    c = total_mass_combination(base)
    if c is None or not ident.results:
        return None
    methods = list(ident.results)
    values = np.array([ident.base["nominal"]] + [ident.results[m].base for m in methods])
    if np.any(values @ c <= 0):
        return None  # the total mass's own check says it
    com = whole_body_com(model, terms, base, np.asarray(q, dtype=float), values, mass=c)
    m, d = model.ff_model, model.ff_model.createData()
    pin.framesForwardKinematics(m, d, np.r_[0, 0, 0, 0, 0, 0, 1.0, model.configuration(q)])
    size = max(float(np.linalg.norm(f.translation)) for f in d.oMf)
    off = {k: float(np.linalg.norm(c - com[0])) for k, c in zip(methods, com[1:])}
    for k, c in zip(methods, com[1:]):
        ident.results[k].info["com"] = c.tolist()
    ident.data["com_urdf"] = com[0].tolist()
    bad = {k: v for k, v in off.items() if v >= COM_WARNED * size}
    if not bad:
        return None
    line = (
        f"{source}: whole-body centre of mass (base frame, mean posture) "
        + ", ".join(
            f"{k} ({', '.join(f'{x:.3g}' for x in com[1 + methods.index(k)])}) m, {v:.3g} m off" for k, v in bad.items()
        )
        + f" against the URDF's ({', '.join(f'{x:.3g}' for x in com[0])}) m; more than {COM_WARNED:.0%} of the robot's "
        f"size ({size:.3g} m): check the wrench's axes and frame (link or world, force plate x/y), the sign of its "
        "moments and the point they are taken about (centre of pressure, sensor origin)"
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
