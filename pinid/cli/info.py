"""``pinid info``: joints, limits and base parameters of a URDF."""

from __future__ import annotations

import argparse

from pinid.cli.common import add_robot_arguments, add_terms_argument, robot_from_args, terms_from_args
from pinid.io import check_writable, write_json

HELP = "show a robot's joints, limits and base parameters"
DESCRIPTION = """\
Reads a URDF (or a bundled / example-robot-data robot name) and prints its active joints with their
limits, the number of standard and base parameters, and each base parameter as a combination of
standard parameters.  Writes nothing unless --json is given.

examples:
  pinid info --urdf urdf/exo_leg.urdf
  pinid info --urdf panda --terms fc,fv,offset --json panda_base.json
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_robot_arguments(p, base=True)
    add_terms_argument(p)
    p.add_argument("--json", metavar="FILE", help="also write the description as JSON to FILE")


def run(args: argparse.Namespace) -> int:
    from pinid.model.describe import describe, description_text  # deferred: pinid --help does not load it

    if args.json:
        check_writable(args.json)
    model = robot_from_args(args)
    terms = terms_from_args(args)
    d = describe(model, terms)
    print(description_text(d, terms))
    if args.json:
        write_json(args.json, d)
        print(f"\nwrote {args.json}")
    return 0
