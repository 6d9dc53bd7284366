"""Passive elastic moments of the wearer's hip, knee and ankle (Riener & Edrich 1999).

``M = Σ sign·exp(c0 + cH·φH + cK·φK + cA·φA) + constant`` [N·m] with the angles in degrees, every moment
positive in the direction its own angle grows; the coefficients live in
``pinid/resources/anthropometry/riener_edrich_1999.toml`` with their source.

Robot joints map to anatomical ones by name (a joint whose name contains ``hip``, ``knee`` or
``ankle`` and none of :data:`NOT_SAGITTAL` — the published moments are about the flexion axes, so a hip
abduction or rotation joint gets none; other joints get no passive moment).  A joint's moment reads the
angles of its own leg: the mapped joints on its kinematic branch (its ancestors and descendants), so on
a two-leg exoskeleton the left knee's biarticular terms see the left hip and ankle.  The anatomical angle is ``s·q``: ``s = +1`` when the
joint's range reaches further on the positive side (``|upper| ≥ |lower|``), else ``-1`` — the larger
excursion is flexion for hip and knee, plantarflexion for the ankle.  exo_leg: hip ``s = +1``, knee
``s = −1`` (its knee flexes negative).  A joint the leg does not have sits at its neutral 0.

In the dynamic model the passive moment is a joint term (``--terms passive``, parameter ``<joint>.kp``,
a dimensionless scale factor of the published shape, nominal 1): the motors supply
``τ = ID(q, dq, ddq) + … − kp·s·M(φ)``, so the term's regressor column is ``−s·M``.  This module registers
the term in :data:`pinid.model.terms.TERMS` (which loads it the first time ``passive`` is asked for,
its entry point of the group ``pinid.terms``, pyproject.toml; :mod:`pinid.plugins`).

The exponents' coefficients ``c`` are the published ones unless the robot carries its own
(``robot.passive_exponents``, ``{anatomical joint: (terms, 4) array}``, saved with a model): what
:mod:`pinid.wearer.exponents` fits.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cache
from importlib import resources

import numpy as np

from pinid.errors import SpecError
from pinid.io import toml_loads
from pinid.model.robot import as_robot
from pinid.model.terms import Term, register
from pinid.checks import array_like

#: Words of a joint name that say it does not turn about a flexion axis (no sagittal passive moment).
NOT_SAGITTAL: tuple[str, ...] = ("abduct", "adduct", "rotat", "invers", "evers")
#: Anatomical joints, in the order of the exponent coefficients (after the constant).
ANATOMICAL: tuple[str, ...] = ("hip", "knee", "ankle")


@cache
def coefficients() -> dict:
    """The Riener & Edrich 1999 table as read from the shipped TOML file."""
    text = (resources.files("pinid.resources") / "anthropometry" / "riener_edrich_1999.toml").read_text(
        encoding="utf-8"
    )
    return toml_loads(text)


def published(joint: str) -> np.ndarray:
    """The published exponent coefficients of anatomical ``joint``: (terms, 4) ``[c0, cH, cK, cA]`` [1, 1/deg]."""
    if not isinstance(joint, str) or joint not in ANATOMICAL:
        raise SpecError(f"joint={joint!r}, expected one of {', '.join(ANATOMICAL)}")
    return np.array([t["c"] for t in coefficients()[joint]["terms"]], dtype=float)


def exponents(robot, joint: str) -> np.ndarray:
    """The exponent coefficients ``robot`` uses for anatomical ``joint``: its own, else the published."""
    if not isinstance(joint, str):
        raise SpecError(f"joint={joint!r}, expected one of {', '.join(ANATOMICAL)}")
    own = (getattr(robot, "passive_exponents", None) or {}).get(joint)
    return published(joint) if own is None else np.asarray(own, dtype=float)


def check_exponents(d: dict, origin: str) -> dict[str, np.ndarray]:
    """``{anatomical joint: (terms, 4) array}`` from a plain dict (a saved model); SpecError naming what is wrong."""
    if not isinstance(d, dict):
        raise SpecError(f"{origin}: got {type(d).__name__}, expected a table of exponent coefficients per joint")
    out = {}
    for joint, c in (d or {}).items():
        want = published(joint).shape if joint in ANATOMICAL else None
        arr = np.asarray(c, dtype=float) if isinstance(c, list) else None
        if want is None or arr is None or arr.shape != want or not np.all(np.isfinite(arr)):
            raise SpecError(
                f"{origin}: {joint!r}: {c!r}, expected one of {list(ANATOMICAL)}: "
                f"{want[0] if want else 'its number of'} rows of 4 finite exponent coefficients"
            )
        out[joint] = arr
    return out


def exponents_to_dict(exps: Mapping) -> dict[str, list]:
    """``{anatomical joint: (terms, 4) list}`` of ``{anatomical joint: (terms, 4) array}`` (the saved form,
    :func:`check_exponents`)."""
    if not isinstance(exps, Mapping):
        raise SpecError(f"exps: got {type(exps).__name__}, expected {{anatomical joint: (terms, 4) array}}")
    return {k: np.asarray(c).tolist() for k, c in exps.items()}


def moment(joint: str, hip: np.ndarray, knee: np.ndarray, ankle: np.ndarray, c: np.ndarray | None = None) -> np.ndarray:
    """Passive moment [N·m] of anatomical ``joint`` at hip, knee and ankle angles [deg] (R&E convention),
    with exponent coefficients ``c`` ((terms, 4); default the published)."""
    if not isinstance(joint, str) or joint not in ANATOMICAL:
        raise SpecError(f"joint={joint!r}, expected one of {', '.join(ANATOMICAL)}")
    row = coefficients()[joint]
    c = published(joint) if c is None else np.asarray(c, dtype=float)
    angles = np.stack(np.broadcast_arrays(np.asarray(hip, float), np.asarray(knee, float), np.asarray(ankle, float)))
    out = np.full(angles.shape[1:], float(row["constant"]))
    for t, ck in zip(row["terms"], c):
        out = out + t["sign"] * np.exp(ck[0] + np.tensordot(ck[1:], angles, axes=1))
    return out


def anatomy(robot) -> list[tuple[str | None, float]]:
    """For each active joint of ``robot``: (anatomical joint or None, sign s of anatomical = s·q)."""
    robot = as_robot(robot)
    out = []
    for j in robot.joints:
        name = j.name.lower()
        kind = next((a for a in ANATOMICAL if a in name), None)
        if any(word in name for word in NOT_SAGITTAL):
            kind = None
        lo, hi = abs(j.lower), abs(j.upper)
        s = 1.0 if not (np.isfinite(lo) and np.isfinite(hi)) or hi >= lo else -1.0
        out.append((kind, s))
    return out


def legs(robot) -> list[dict[str, int]]:
    """For each active joint of ``robot``: ``{anatomical joint: index}`` of the mapped joints on its
    kinematic branch (its ancestors, itself and its descendants), i.e. of its own leg; empty when unmapped."""
    robot = as_robot(robot)
    amap = anatomy(robot)
    parents = robot.pin_model.parents  # Pinocchio joint i + 1 is the robot's joint i

    def ancestors(i: int) -> set[int]:
        out, k = set(), parents[i + 1]
        while k > 0:
            out.add(k - 1)
            k = parents[k]
        return out

    above = [ancestors(i) for i in range(len(amap))]
    out = []
    for i, (kind, _) in enumerate(amap):
        branch = above[i] | {i} | {k for k in range(len(amap)) if i in above[k]}
        out.append({amap[k][0]: k for k in sorted(branch) if amap[k][0] is not None} if kind else {})
    return out


def column(q: np.ndarray, robot, exps: dict[str, np.ndarray] | None = None) -> np.ndarray:
    """Regressor column (N, nv) of the passive scale factors: ``−s·M`` per mapped joint [N·m], 0 elsewhere;
    exponent coefficients from ``exps`` ``{anatomical joint: (terms, 4)}``, else :func:`exponents`."""
    array_like(q, "q")
    q = np.atleast_2d(np.asarray(q, dtype=float))
    exps = exps or {}
    amap = anatomy(robot)
    zero = np.zeros(q.shape[0])
    out = np.zeros_like(q)
    for i, ((kind, s), leg) in enumerate(zip(amap, legs(robot))):
        if kind is not None:
            deg = {a: np.degrees(amap[k][1] * q[:, k]) if (k := leg.get(a)) is not None else zero for a in ANATOMICAL}
            out[:, i] = -s * moment(kind, deg["hip"], deg["knee"], deg["ankle"], exps.get(kind, exponents(robot, kind)))
    return out


def passive_torque(q: np.ndarray, robot, scale: np.ndarray | float = 1.0) -> np.ndarray:
    """Passive moment the wearer's tissues apply on the robot's joints [N·m], (N, nv): ``scale·s·M``."""
    array_like(q, "q")
    return -np.asarray(scale, dtype=float) * column(q, robot)


register(
    Term(
        "passive",
        "kp",
        "wearer passive moment (scale of Riener & Edrich 1999)",
        "1",
        lambda m: column(m.q, m.robot),
        static=True,
        nominal=lambda r: np.array([1.0 if kind else 0.0 for kind, _ in anatomy(r)]),
        setting="passive_exponents",
        read_setting=check_exponents,
        write_setting=exponents_to_dict,
        note="docs/wearer.md",
    )
)
