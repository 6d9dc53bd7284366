"""A robot described for people and for JSON: its joints and limits, drives, terms and base parameters
(what ``pinid info`` prints and writes)."""

from __future__ import annotations

import numpy as np

from pinid.errors import ModelError
from pinid.model.base import base_parameters
from pinid.model.regressor import JointTerms, standard_parameters
from pinid.model.robot import RobotModel


def describe(model: RobotModel, terms: JointTerms) -> dict:
    """Plain-dict description of a model and its base parameters (with their expressions in the standard
    parameters and their URDF values)."""
    bp = base_parameters(model, terms)
    nominal = bp.from_standard(standard_parameters(model, terms))
    return {
        "robot": model.name,
        "urdf": str(model.urdf_path),
        "joints": [
            {
                "name": j.name,
                "type": j.kind,
                "lower": _num(j.lower),
                "upper": _num(j.upper),
                "velocity": _num(j.velocity),
                "effort": _num(j.effort),
            }
            for j in model.joints
        ],
        "locked": model.locked,
        "drives": None
        if model.drives is None
        else {"source": model.drives.origin, "motors": model.motor_names, "matrix": model.drives.matrix.tolist()},
        "terms": terms.names,
        "standard_parameters": len(bp.standard_names),
        "base_parameters": [
            {"name": n, "expression": e, "nominal": float(v)} for n, e, v in zip(bp.names, bp.expressions(), nominal)
        ],
        "unidentifiable": bp.unidentifiable,
    }


def _num(x: float):
    return None if not np.isfinite(x) else float(x)


def description_text(d: dict, terms: JointTerms) -> str:
    """:func:`describe`'s dict as text: a table of the joints, the locked joints, the drives' matrix, and
    every base parameter as a combination of standard parameters with its URDF value."""
    if not isinstance(d, dict):
        raise ModelError(f"d: got {type(d).__name__}, expected the dict of describe()")
    out = [
        f"robot {d['robot']}  ({d['urdf']})",
        f"{'joint':<24}{'type':<12}{'lower':>10}{'upper':>10}{'velocity':>10}{'effort':>10}",
    ]
    for j in d["joints"]:
        cells = [("-" if j[k] is None else f"{j[k]:.4g}") for k in ("lower", "upper", "velocity", "effort")]
        out.append(f"{j['name']:<24}{j['type']:<12}" + "".join(f"{c:>10}" for c in cells))
    if d["locked"]:
        out.append("locked: " + ", ".join(f"{k}={v:g}" for k, v in d["locked"].items()))
    if d["drives"]:
        out.append(f"drives ({d['drives']['source']}): q_motor = G·q_joint, rows {', '.join(d['drives']['motors'])}")
        for m, row in zip(d["drives"]["motors"], d["drives"]["matrix"]):
            out.append(f"  {m:<22}" + "".join(f"{x:>10.4g}" for x in row))
    nb = len(d["base_parameters"])
    per = [f"{', '.join(t.name for t in terms.joint)} per joint"] if terms.joint else []
    per += [f"{', '.join(t.name for t in terms.motor)} per motor"] if terms.motor else []
    out.append(
        f"\n{d['standard_parameters']} standard parameters (10 inertial per body + {'; '.join(per) or 'no terms'}), "
        f"{nb} base parameters:"
    )
    width = max(len(b["name"]) for b in d["base_parameters"])
    for b in d["base_parameters"]:
        out.append(f"  {b['name']:<{width}} = {b['expression']}    (URDF: {b['nominal']:.6g})")
    return "\n".join(out)
