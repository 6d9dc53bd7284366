"""``pinid track``: closed-loop tracking on the digital twin with a model-based controller."""

from __future__ import annotations

import argparse
from pathlib import Path

from pinid.cli.common import nonnegative_float, robot_from_args, seed_int, wrote_line
from pinid.errors import SpecError
from pinid.io import check_outputs

HELP = "track a reference on the twin with backstepping / computed torque built on a model"
DESCRIPTION = """\
Reads the "true" leg (--urdf-true: URDF with its friction in <dynamics>), the controller's model
(--model: 'nominal', 'cad:30' — the true URDF's inertial parameters about 30 % off and friction
ignored, as a CAD model would be —, a URDF, results/model_<method>.json or results/identification.json), and a
reference (--reference: a trajectory JSON from pinid excite, or 'sine' — seed 001's 4 s sinusoid, kept
inside the joint limits).  Simulates the closed loop with each controller and prints the tracking
error per joint (RMS and max after the start-up, settling time and the band it settles into: 2 % of
the joint's reference range, at least 1 mrad).  Writes FOLDER/tracking.json,
FOLDER/tracking_<controller>.png (per joint: reference and response, error, torque of every model) and
FOLDER/tracking_models.png (the RMS error per joint of every model × controller as grouped bars; a log
scale when they span more than 100×); --no-figures: the JSON only.

examples:
  pinid track --urdf-true urdf/exo_leg.urdf --model results/identification.json -o results/track
  pinid track --urdf-true exo_leg --model nominal --model results/model_sdp.json --seconds 8
  pinid track --urdf-true exo_leg --model cad:30 --model results/identification.json
  pinid track --urdf-true exo_with_wearer.urdf --wearer-draw --seed 2 --model results_exo/model_sdp.json \\
      --model results_wearer/model_table.json --model results_wearer/model_wearer.json
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--urdf-true", default="exo_leg", help="the plant's URDF or robot name; default exo_leg")
    p.add_argument(
        "--drives",
        default=None,
        metavar="FILE",
        help="the plant's drives TOML (docs/drives.md): its [motors.NAME] friction and rotor inertia "
        "act in the plant; replaces the URDF's <transmission>",
    )
    p.add_argument(
        "--model",
        action="append",
        default=[],
        metavar="SPEC",
        help="controller model: nominal | cad:PERCENT | FILE.urdf | model_<method>.json | identification.json; "
        "repeatable",
    )
    p.add_argument("--no-friction", action="store_true", help="ignore <dynamics> friction in URDF / nominal models")
    p.add_argument("--reference", default="sine", help="trajectory JSON or 'sine' (default)")
    p.add_argument(
        "--controller",
        default="backstepping,computed-torque",
        help="comma-separated: backstepping, computed-torque; default both",
    )
    p.add_argument("--seconds", type=float, default=8.0, help="duration [s]; default 8")
    p.add_argument("--after", type=float, default=2.0, help="start of the error statistics [s]; default 2")
    p.add_argument("--position-noise", type=nonnegative_float, default=2e-5, help="encoder noise σ [rad]; default 2e-5")
    p.add_argument("--seed", type=seed_int, default=0, help="noise seed (and the cad: perturbation's); default 0")
    p.add_argument(
        "--wearer-draw",
        action="store_true",
        help="the plant's wearer (a URDF from pinid wearer) drawn away from the tables as pinid simulate "
        "--wearer-draw does with the same --seed: the same true wearer",
    )
    p.add_argument("-o", "--output", default=None, metavar="FOLDER", help="write tracking.json and plots here")
    p.add_argument("--no-figures", action="store_true", help="with -o: write tracking.json only (no PNG)")


def run(args: argparse.Namespace) -> int:
    # deferred: pinid.control loads the twin (~15 ms that pinid --help would pay)
    from pinid.control.controllers import compare_models, load_controller_model
    from pinid.control.tracking import load_reference, tracking_paths, tracking_table, write_tracking
    from pinid.wearer.attach import wearer_links  # the plant's wearer, handed to the twin (folders are layers)

    controllers = tuple(c.strip() for c in args.controller.split(",") if c.strip())
    if args.output is not None:  # fail before the work, creating nothing
        check_outputs(*tracking_paths(args.output, controllers, figures=not args.no_figures))
    if not (args.seconds > args.after >= 0):
        raise SpecError(f"--seconds {args.seconds} and --after {args.after}: expected seconds > after >= 0")
    plant = robot_from_args(args, urdf=args.urdf_true)  # with the plant's --drives
    if args.wearer_draw:
        from pinid.wearer.prior import draw_wearer  # deferred: pinid --help does not load it

        plant, _ = draw_wearer(plant, args.seed)
    reference = load_reference(args.reference, plant)
    models = {
        s: load_controller_model(s, plant, friction=not args.no_friction, seed=args.seed)
        for s in args.model or ["nominal"]
    }
    table = compare_models(
        plant,
        models,
        reference,
        controllers=controllers,
        seconds=args.seconds,
        after=args.after,
        position_noise=args.position_noise,
        seed=args.seed,
        wearer=wearer_links(plant.urdf_text) if plant.urdf_text else None,
    )
    print(tracking_table(table, after=args.after))
    if args.output is not None:
        settings = {"reference": args.reference, "seconds": args.seconds, "after": args.after, "seed": args.seed}
        written = write_tracking(table, args.output, plant=plant, settings=settings, figures=not args.no_figures)
        print(wrote_line(written, Path(args.output)))
    return 0
