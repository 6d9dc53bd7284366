"""A wearer's comfort limits for excitation design: range, speed and acceleration of hip, knee, ankle.

The limits (degrees, deg/s, deg/s², anatomical convention) come from a TOML file; the shipped default
``pinid/resources/anthropometry/comfort_limits.toml`` states its sources.  Each anatomical joint maps
to the robot's joint of that name (:func:`pinid.wearer.passive.anatomy`, anatomical angle = s·q); the
design then runs within the intersection with the spec's (URDF's) limits.  A comfort range that does
not overlap the URDF's range is an error (the exoskeleton cannot move there).
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path

import numpy as np

from pinid.errors import SpecError
from pinid.io import read_toml
from pinid.wearer.passive import ANATOMICAL, anatomy

_KEYS = {"min", "max", "speed", "acceleration"}


def default_path() -> Path:
    """The shipped comfort limits."""
    return Path(str(resources.files("pinid.resources") / "anthropometry" / "comfort_limits.toml"))


def read_limits(path: str | Path | None = None) -> dict[str, dict[str, float]]:
    """``{anatomical joint: {min, max [deg], speed [deg/s], acceleration [deg/s²]}}`` from ``path`` (default
    the shipped file), checked."""
    p = Path(path) if path is not None else default_path()
    data = read_toml(p, "comfort limits file")  # regular file, bounded size, depth-limited
    out = {}
    for joint, table in data.items():
        if joint not in ANATOMICAL or not isinstance(table, dict) or set(table) != _KEYS:
            raise SpecError(
                f"{p}: [{joint}]: expected tables [hip], [knee], [ankle] with keys {', '.join(sorted(_KEYS))}"
            )
        v = {k: table[k] for k in _KEYS}
        if (
            not all(isinstance(x, (int, float)) and math.isfinite(x) for x in v.values())
            or v["min"] >= v["max"]
            or v["speed"] <= 0
            or v["acceleration"] <= 0
        ):
            raise SpecError(f"{p}: [{joint}]: expected min < max [deg], speed > 0 [deg/s], acceleration > 0 [deg/s²]")
        out[joint] = {k: float(x) for k, x in v.items()}
    return out


def within_comfort(spec, model, path: str | Path | None = None):
    """``spec`` (an ExcitationSpec for ``model``) restricted to the comfort limits of ``path``: position
    ranges intersected, speed and acceleration the smaller; offsets outside the new range move to its
    centre.  SpecError when a comfort range does not overlap the spec's (URDF's) range."""
    limits = read_limits(path)
    lo, hi, dq, ddq, q0 = (getattr(spec, k).copy() for k in ("q_min", "q_max", "dq_max", "ddq_max", "q0"))
    src = str(path) if path is not None else "comfort_limits.toml (pinid's default)"
    for i, (kind, s) in enumerate(anatomy(model)):
        c = limits.get(kind) if kind else None
        if c is None:
            continue
        a, b = sorted((math.radians(c["min"]) / s, math.radians(c["max"]) / s))
        name = model.joint_names[i]
        if a >= hi[i] or b <= lo[i]:
            raise SpecError(
                f"{src}: {kind} comfort range [{c['min']:g}, {c['max']:g}] deg is joint '{name}' "
                f"[{a:.4g}, {b:.4g}] rad, outside its limits [{lo[i]:.4g}, {hi[i]:.4g}] rad; "
                "expected comfort limits that overlap the URDF's"
            )
        lo[i], hi[i] = max(lo[i], a), min(hi[i], b)
        dq[i] = min(dq[i], math.radians(c["speed"]))
        ddq[i] = min(ddq[i], math.radians(c["acceleration"]))
        if not lo[i] < q0[i] < hi[i]:
            q0[i] = 0.5 * (lo[i] + hi[i])
    return spec.replace(
        q_min=lo,
        q_max=hi,
        dq_max=dq,
        ddq_max=ddq,
        q0=np.asarray(q0),
        source=f"{spec.source} within the comfort limits of {src}",
    )
