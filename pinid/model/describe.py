"""A robot described for people and for JSON: its joints and limits, drives, terms and base parameters
(what ``pinid info`` prints and writes)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pinid.errors import ModelError
from pinid.model.base import base_parameters
from pinid.model.regressor import standard_parameters
from pinid.model.terms import TermSelection
from pinid.model.robot import RobotModel


def describe(model: RobotModel, terms: TermSelection) -> dict:
    """Plain-dict description of a model and its base parameters (with their expressions in the standard
    parameters, their nominal values and where those come from: the URDF, the drives file or both)."""
    floating = getattr(model, "base", "fixed") == "floating"
    bp = base_parameters(model, terms)  # a floating robot's: base link first (they dispatch on the model)
    nominal = bp.from_standard(standard_parameters(model, terms))
    if floating:
        from_base_rows = base_parameters(model, terms, rows="base")
    motors = set(model.motor_names)
    drives = None if model.drives is None else Path(model.drives.origin.split(" <")[0]).name

    def source(row: np.ndarray) -> str:
        """Where a base parameter's nominal value comes from: the URDF, the drives file, or both."""
        used = {bp.standard_names[i].split(".")[0] in motors for i in np.flatnonzero(row)}
        return " + ".join(([] if used == {True} else ["URDF"]) + ([drives] if True in used else []))

    out = {
        "robot": model.name,
        "urdf": str(model.urdf_path),
        "base": "floating" if floating else "fixed",
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
            {"name": n, "expression": e, "nominal": float(v), "source": source(row)}
            for n, e, v, row in zip(bp.names, bp.expressions(), nominal, bp.P)
        ],
        "unidentifiable": bp.unidentifiable,
    }
    if floating:
        out["base_link"] = model.base_link
        out["base_rows"] = {
            "count": from_base_rows.count,
            "names": from_base_rows.names,
            "expressions": from_base_rows.expressions(),
        }
    return out


#: Units of a joint's limits (position, position, velocity, effort): revolute [0], prismatic [1].
UNITS = (("rad", "rad", "rad/s", "N·m"), ("m", "m", "m/s", "N"))


def _num(x: float):
    return None if not np.isfinite(x) else float(x)


def description_text(d: dict, terms: TermSelection) -> str:
    """:func:`describe`'s dict as text: a table of the joints with the units of their limits ([rad, rad/s,
    N·m], [m, m/s, N] for prismatic joints), the locked joints, the drives' matrix, and every base parameter
    as a combination of standard parameters with its nominal value and where that comes from."""
    if not isinstance(d, dict):
        raise ModelError(f"d: got {type(d).__name__}, expected the dict of describe()")
    units = [UNITS[j["type"] == "prismatic"] for j in d["joints"]]
    same = len(set(units)) == 1  # the units in the header, else in a last column
    heads = ["lower", "upper", "velocity", "effort"]
    if same:
        heads = [f"{h} [{u}]" for h, u in zip(heads, units[0])]
    widths = [max(10, len(h) + 2) for h in heads]
    out = [
        f"robot {d['robot']}  ({d['urdf']})",
        f"{'joint':<24}{'type':<12}"
        + "".join(f"{h:>{w}}" for h, w in zip(heads, widths))
        + ("" if same else "  units"),
    ]
    for j, u in zip(d["joints"], units):
        cells = [("-" if j[k] is None else f"{j[k]:.4g}") for k in ("lower", "upper", "velocity", "effort")]
        tail = "" if same else f"  {', '.join(u[1:])}"
        out.append(f"{j['name']:<24}{j['type']:<12}" + "".join(f"{c:>{w}}" for c, w in zip(cells, widths)) + tail)
    if d["locked"]:
        out.append("locked: " + ", ".join(f"{k}={v:g}" for k, v in d["locked"].items()))
    if d["drives"]:
        out.append(f"drives ({d['drives']['source']}): q_motor = G·q_joint, rows {', '.join(d['drives']['motors'])}")
        for m, row in zip(d["drives"]["motors"], d["drives"]["matrix"]):
            out.append(f"  {m:<22}" + "".join(f"{x:>10.4g}" for x in row))
    if d.get("base") == "floating":
        out.append(
            f"base: floating (free flyer under link '{d['base_link']}'; parameters 'base.*' are that link's, "
            "6 base rows per sample before the joint rows)"
        )
    nb = len(d["base_parameters"])
    per = [f"{', '.join(t.name for t in terms.joint)} per joint"] if terms.joint else []
    per += [f"{', '.join(t.name for t in terms.motor)} per motor"] if terms.motor else []
    out.append(
        f"\n{d['standard_parameters']} standard parameters (10 inertial per body + {'; '.join(per) or 'no terms'}), "
        f"{nb} base parameters:"
    )
    width = max(len(b["name"]) for b in d["base_parameters"])
    for b in d["base_parameters"]:
        out.append(f"  {b['name']:<{width}} = {b['expression']}    ({b.get('source', 'URDF')}: {b['nominal']:.6g})")
    if d.get("base_rows"):
        rows = d["base_rows"]
        out.append(
            f"\nfrom the 6 base rows alone (contact wrenches and motion, no joint torque): {rows['count']} of "
            f"these combinations are identifiable:"
        )
        width = max(len(n) for n in rows["names"])
        out.extend(f"  {n:<{width}} = {e}" for n, e in zip(rows["names"], rows["expressions"]))
    return "\n".join(out)
