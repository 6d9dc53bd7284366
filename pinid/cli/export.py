"""``pinid export``: an identified model as MuJoCo MJCF or URDF."""

from __future__ import annotations

import argparse

from pinid.errors import SpecError
from pinid.io import check_writable

HELP = "write an identified model as MuJoCo MJCF (or URDF)"
DESCRIPTION = """\
Reads an identification (identification.json of pinid identify: its best method, or --method) or an
identified model (model_<method>.json) and writes it as MuJoCo MJCF (--format mjcf, the default; see
docs/mujoco.md) or as URDF.  A physically inconsistent model, or one with a body MuJoCo refuses (massless,
a zero principal moment), is refused: one line, exit status 2, nothing written.  pinid identify already
writes identified_<method>.xml beside identified_<method>.urdf for every consistent method.  A floating
identification (pinid identify --base floating) is recognised from its robot: the MJCF's root body then has
a free joint and the identified base-link inertia (base.*), with or without --floating.

examples:
  pinid export --model results/identification.json -o model.xml
  pinid export --model results/model_sdp.json --format mjcf --floating -o exo_floating.xml
  pinid export --model results/identification.json --method sdp --format urdf -o exo_sdp.urdf
  pinid export --model res_floating/identification.json -o exo_floating.xml
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--model", required=True, metavar="FILE", help="identification.json or model_<method>.json")
    p.add_argument("--method", help="the method of an identification.json to export (default: its best)")
    p.add_argument("--format", choices=("mjcf", "urdf"), default="mjcf", help="output format (default: mjcf)")
    p.add_argument(
        "--floating", action="store_true", help="MJCF: a free joint on the root link (default: welded to the world)"
    )
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="the file to write")


def run(args: argparse.Namespace) -> int:
    from pinid.identification.result import load_identified  # deferred: pinid --help does not load it

    if args.floating and args.format != "mjcf":
        raise SpecError("--floating is for --format mjcf (a URDF has no free joint)")
    out = check_writable(args.output, inputs=(args.model,))  # never the file it reads, --force or not
    model = load_identified(args.model, method=args.method)
    if args.format == "mjcf":
        model.export_mjcf(out, floating=args.floating or None)
    else:
        model.export_urdf(out)
    floating = ", floating base" if getattr(model.nominal_robot, "base", "fixed") == "floating" else ""
    print(f"wrote {args.output} ({args.format}{floating}, method {model.meta.get('method', '?')})")
    return 0
