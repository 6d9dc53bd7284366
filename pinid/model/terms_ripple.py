"""Position-periodic torque ripple (motor cogging, gear ripple): a few harmonics of the motor angle per joint.

    τ_ripple,j = Σ_k  s_jk·sin(k·r_j·q_j) + c_jk·cos(k·r_j·q_j)      [N·m],  k = 1 … K (K ≤ 3)

``r_j`` is the number of ripple periods per revolution of joint ``j``: the model setting ``"ripple_periods"``
(one number for every joint, or ``{joint: number}``), else the reduction ratio of the joint's drive — ``|G[m, j]|``
of the motor ``m`` that turns joint ``j`` most (one period per motor revolution; exact for a transmission row
``θ_m = r·q_j``) — and ModelError when the model has neither.  The setting is saved with the model.

A term is one parameter per joint, so each amplitude is its own term: ``ripple_s1``, ``ripple_c1`` (the first
harmonic's sine and cosine), ``ripple_s2``, ``ripple_c2``, ``ripple_s3``, ``ripple_c3``; parameters
``<joint>.ripple_s1`` [N·m], signed.  The selection groups of :data:`pinid.model.terms.TERM_GROUPS` name them
together: ``--terms fc,fv,ripple`` (K = 1), ``ripple2`` (K = 2), ``ripple3``.  The columns depend on q only
(``static``: :meth:`IdentifiedModel.gravity` includes them); the twin's plant applies value × column.

Registered in :data:`pinid.model.terms.TERMS` when one of its names is first asked for
(its entry point of the group ``pinid.terms``, pyproject.toml; :mod:`pinid.plugins`).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from pinid.errors import ModelError, SpecError
from pinid.model.terms import Motion, Term, register

#: The model setting that holds the ripple periods per joint revolution.
SETTING = "ripple_periods"
#: The highest harmonic registered.
HARMONICS = 3


def _period(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.number)) or not np.isfinite(value):
        raise SpecError(f"{where}: {value!r}, expected a number of ripple periods per joint revolution > 0")
    if value <= 0:
        raise SpecError(f"{where}: {value!r}, expected a number of ripple periods per joint revolution > 0")
    return float(value)


def _read_periods(saved, origin: str) -> float | dict[str, float]:
    """The ripple periods as given or saved: a number > 0 for every joint, or ``{joint: number > 0}``;
    ``origin`` names the place in the SpecError."""
    if isinstance(saved, Mapping):
        if not saved or not all(isinstance(k, str) for k in saved):
            raise SpecError(f"{origin}: {saved!r}, expected {{joint: ripple periods per revolution > 0}}")
        return {k: _period(v, f"{origin}: {k}") for k, v in saved.items()}
    return _period(saved, origin)


def periods_from_text(text: str, origin: str = "--ripple-periods") -> float | dict[str, float]:
    """``"160"`` (every joint) or ``"A1=160,A2=100"`` as :func:`_read_periods` returns it; SpecError otherwise."""
    if not isinstance(text, str) or not isinstance(origin, str):
        raise SpecError(f"text: got {type(text).__name__}, expected ripple periods 'R' or 'JOINT=R,…'")
    parts = [p.strip() for p in text.split(",") if p.strip()]
    try:
        if len(parts) == 1 and "=" not in parts[0]:
            return _read_periods(float(parts[0]), origin)
        pairs = [p.partition("=") for p in parts]
        if not pairs or any(not sep or not k.strip() for k, sep, _ in pairs):
            raise ValueError
        return _read_periods({k.strip(): float(v) for k, _, v in pairs}, origin)
    except ValueError as exc:
        if isinstance(exc, SpecError):
            raise
        raise SpecError(
            f"{origin} {text!r}: expected a number > 0 (every joint) or JOINT=R,… e.g. A1=160,A2=160"
        ) from None


def _write_periods(value) -> float | dict[str, float]:
    return {k: float(v) for k, v in value.items()} if isinstance(value, Mapping) else float(value)


def periods(robot) -> np.ndarray:
    """Ripple periods per revolution of each joint (nv,): the model's ``"ripple_periods"`` setting, else its
    drives' reduction ratio; ModelError naming the joints that have neither."""
    if not (hasattr(robot, "joint_names") and hasattr(robot, "setting")):
        raise ModelError(f"robot: got {type(robot).__name__}, expected a pinid RobotModel")
    given = robot.setting(SETTING)
    names = list(robot.joint_names)
    out = np.full(len(names), np.nan)
    if isinstance(given, Mapping):
        unknown = sorted(set(given) - set(names))
        if unknown:
            raise ModelError(f"ripple periods for {unknown}: not joints of {robot.name}, expected some of {names}")
        for j, name in enumerate(names):
            out[j] = given.get(name, np.nan)
    elif given is not None:
        out[:] = float(given)
    drives = getattr(robot, "drives", None)
    if drives is not None and np.isnan(out).any():
        G = np.abs(np.asarray(drives.matrix, dtype=float))
        ratio = G[np.argmax(G, axis=0), np.arange(len(names))]
        out = np.where(np.isnan(out) & (ratio > 0), ratio, out)
    if np.isnan(out).any():
        missing = [n for n, r in zip(names, out) if np.isnan(r)]
        raise ModelError(
            f"position ripple: no ripple periods per revolution for joint(s) {missing} of {robot.name}: give "
            "--ripple-periods R (or JOINT=R,…; model.with_setting('ripple_periods', R)) or the robot's drives"
        )
    return out


def _ripple_term(k: int, kind: str) -> Term:
    """The sine (``kind`` "s") or cosine ("c") amplitude of harmonic ``k``."""
    f = np.sin if kind == "s" else np.cos

    def column(m: Motion) -> np.ndarray:
        return f(k * periods(m.robot) * m.q)

    name = f"ripple_{kind}{k}"
    return Term(
        name,
        name,
        f"position ripple, {'sine' if kind == 's' else 'cosine'} of harmonic {k}",
        "N·m",
        column,
        static=True,
        setting=SETTING,
        read_setting=_read_periods,
        write_setting=_write_periods,
    )


for _k in range(1, HARMONICS + 1):
    for _kind in "sc":
        register(_ripple_term(_k, _kind))
