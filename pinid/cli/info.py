"""``pinid info``: joints, limits and base parameters of a URDF."""

from __future__ import annotations

import argparse

import numpy as np

from pinid.cli.common import add_robot_arguments, add_terms_argument, robot_from_args, terms_from_args

HELP = "show a robot's joints, limits and base parameters"
DESCRIPTION = """\
Reads a URDF (or a bundled / example-robot-data robot name) and prints its active joints with their
limits, the number of standard and base parameters, and each base parameter as a combination of
standard parameters.  Writes nothing unless --json is given.

example:
  pinid info --urdf urdf/exo_leg.urdf
  pinid info --urdf panda --terms fc,fv,offset --json panda_base.json
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_robot_arguments(p)
    add_terms_argument(p)
    p.add_argument("--json", metavar="FILE", help="also write the description as JSON to FILE")


def describe(model, terms) -> dict:
    """Plain-dict description of a model and its base parameters."""
    from pinid.model.base import base_parameters
    from pinid.model.regressor import standard_parameters

    bp = base_parameters(model, terms)
    nominal = bp.from_standard(standard_parameters(model, terms))
    return {
        "robot": model.name,
        "urdf": str(model.urdf_path),
        "joints": [
            {"name": j.name, "type": j.kind, "lower": _num(j.lower), "upper": _num(j.upper),
             "velocity": _num(j.velocity), "effort": _num(j.effort)}
            for j in model.joints
        ],
        "locked": model.locked,
        "drives": None if model.drives is None else {
            "source": model.drives.origin, "motors": model.motor_names, "matrix": model.drives.matrix.tolist()},
        "terms": terms.names,
        "standard_parameters": len(bp.standard_names),
        "base_parameters": [
            {"name": n, "expression": e, "nominal": float(v)}
            for n, e, v in zip(bp.names, bp.expressions(), nominal)
        ],
        "unidentifiable": bp.unidentifiable,
    }


def _num(x: float):
    return None if not np.isfinite(x) else float(x)


def run(args: argparse.Namespace) -> int:
    from pinid.io import check_writable, write_json

    if args.json:
        check_writable(args.json)
    model = robot_from_args(args)
    terms = terms_from_args(args)
    d = describe(model, terms)
    print(f"robot {d['robot']}  ({d['urdf']})")
    print(f"{'joint':<24}{'type':<12}{'lower':>10}{'upper':>10}{'velocity':>10}{'effort':>10}")
    for j in d["joints"]:
        cells = [("-" if j[k] is None else f"{j[k]:.4g}") for k in ("lower", "upper", "velocity", "effort")]
        print(f"{j['name']:<24}{j['type']:<12}" + "".join(f"{c:>10}" for c in cells))
    if d["locked"]:
        print("locked: " + ", ".join(f"{k}={v:g}" for k, v in d["locked"].items()))
    if d["drives"]:
        print(f"drives ({d['drives']['source']}): q_motor = G·q_joint, rows {', '.join(d['drives']['motors'])}")
        for m, row in zip(d["drives"]["motors"], d["drives"]["matrix"]):
            print(f"  {m:<22}" + "".join(f"{x:>10.4g}" for x in row))
    nb = len(d["base_parameters"])
    per = [f"{', '.join(t.name for t in terms.joint)} per joint"] if terms.joint else []
    per += [f"{', '.join(t.name for t in terms.motor)} per motor"] if terms.motor else []
    print(f"\n{d['standard_parameters']} standard parameters (10 inertial per body + {'; '.join(per) or 'no terms'}), "
          f"{nb} base parameters:")
    width = max(len(b["name"]) for b in d["base_parameters"])
    for b in d["base_parameters"]:
        print(f"  {b['name']:<{width}} = {b['expression']}    (URDF: {b['nominal']:.6g})")
    if args.json:
        write_json(args.json, d)
        print(f"\nwrote {args.json}")
    return 0
