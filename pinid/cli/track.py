"""``pinid track``: closed-loop tracking on the digital twin with a model-based controller."""

from __future__ import annotations

import argparse

from pinid.cli.common import nonnegative_float, seed_int, wrote_line

HELP = "track a reference on the twin with backstepping / computed torque built on a model"
DESCRIPTION = """\
Reads the "true" leg (--urdf-true: URDF with its friction in <dynamics>), the controller's model
(--model: 'nominal', 'cad:30' — the true URDF's inertial parameters about 30 % off and friction
ignored, as a CAD model would be —, a URDF, results/model_<method>.json or results/identification.json), and a
reference (--reference: a trajectory JSON from pinid excite, or 'sine' — seed 001's 4 s sinusoid, kept
inside the joint limits).  Simulates the closed loop with each controller and prints the tracking
error per joint (RMS and max after the start-up, settling time).  Writes FOLDER/tracking.json and
FOLDER/tracking_<controller>.png.

example:
  pinid track --urdf-true urdf/exo_leg.urdf --model results/identification.json -o results/track
  pinid track --urdf-true exo_leg --model nominal --model results/model_sdp.json --seconds 8
  pinid track --urdf-true exo_leg --model cad:30 --model results/identification.json
  pinid track --urdf-true exo_with_wearer.urdf --wearer-draw --seed 2 --model results_exo/model_sdp.json \
      --model results_wearer/model_table.json --model results_wearer/model_wearer.json
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--urdf-true", default="exo_leg", help="the plant's URDF or robot name; default exo_leg")
    p.add_argument("--drives", default=None, metavar="FILE",
                   help="the plant's drives TOML (docs/drives.md): its [motors.NAME] friction and rotor inertia "
                        "act in the plant; replaces the URDF's <transmission>")
    p.add_argument("--model", action="append", default=[], metavar="SPEC",
                   help="controller model: nominal | cad:PERCENT | FILE.urdf | model_<method>.json | identification.json; "
                        "repeatable")
    p.add_argument("--no-friction", action="store_true", help="ignore <dynamics> friction in URDF / nominal models")
    p.add_argument("--reference", default="sine", help="trajectory JSON or 'sine' (default)")
    p.add_argument("--controller", default="backstepping,computed-torque",
                   help="comma-separated: backstepping, computed-torque; default both")
    p.add_argument("--seconds", type=float, default=8.0, help="duration [s]; default 8")
    p.add_argument("--after", type=float, default=2.0, help="start of the error statistics [s]; default 2")
    p.add_argument("--position-noise", type=nonnegative_float, default=2e-5, help="encoder noise σ [rad]; default 2e-5")
    p.add_argument("--seed", type=seed_int, default=0, help="noise seed (and the cad: perturbation's); default 0")
    p.add_argument("--wearer-draw", action="store_true",
                   help="the plant's wearer (a URDF from pinid wearer) drawn away from the tables as pinid simulate "
                        "--wearer-draw does with the same --seed: the same true wearer")
    p.add_argument("-o", "--output", default=None, metavar="FOLDER", help="write tracking.json and plots here")


def sine_reference(plant):
    """Seed 001's reference, x_d = sin(0.5πt), scaled into the middle of each joint's range."""
    import numpy as np

    from pinid.excitation.trajectory import FourierTrajectory

    lo = np.where(np.isfinite(plant.lower), plant.lower, -1.0)
    hi = np.where(np.isfinite(plant.upper), plant.upper, 1.0)
    centre, amp = 0.5 * (lo + hi), np.minimum(0.35 * (hi - lo), 0.6)
    return FourierTrajectory(plant.joint_names, 0.5 * np.pi, centre, amp[:, None], np.zeros((plant.nv, 1)))


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    import numpy as np

    from pinid.control.controllers import compare_models, load_controller_model
    from pinid.errors import SpecError
    from pinid.io import Artefacts, check_outputs, json_text
    from pinid.model.robot import RobotModel
    from pinid.excitation.trajectory import FourierTrajectory
    from pinid.report.text import text_table

    out = Path(args.output) if args.output else None
    controllers = tuple(c.strip() for c in args.controller.split(",") if c.strip())
    if out is not None:  # fail before the work, creating nothing
        check_outputs(out / "tracking.json", *(out / f"tracking_{c}.png" for c in controllers))
    if not (args.seconds > args.after >= 0):
        raise SpecError(f"--seconds {args.seconds} and --after {args.after}: expected seconds > after >= 0")
    plant = RobotModel.from_urdf(args.urdf_true)
    if args.drives:
        from pinid.model.drives import attach

        attach(plant, args.drives)
    if args.wearer_draw:
        from pinid.wearer.prior import draw_wearer

        plant, _ = draw_wearer(plant, args.seed)
    reference = sine_reference(plant) if args.reference == "sine" else FourierTrajectory.load(args.reference)
    reference = reference.for_joints(plant.joint_names, plant.name)
    specs = args.model or ["nominal"]
    models = {s: load_controller_model(s, plant, friction=not args.no_friction, seed=args.seed) for s in specs}
    table = compare_models(plant, models, reference, controllers=controllers, seconds=args.seconds,
                           after=args.after, position_noise=args.position_noise, seed=args.seed)
    rows = []
    for c, per_model in table.items():
        for name, entry in per_model.items():
            label = name if name == "nominal" else Path(name).name
            for joint, m in entry["metrics"].items():
                settle = "never" if not np.isfinite(m["settling_time"]) else f"{m['settling_time']:.2f}"
                rows.append([c, label, joint, f"{1e3 * m['rms']:.3f}", f"{1e3 * m['max_abs']:.3f}", settle])
    print(text_table(["controller", "model", "joint", "RMS [mrad]", "max [mrad]", "settle [s]"], rows, keys=3))
    if out is not None:
        from pinid.report.figures import save_figure
        from pinid.report.plot_control import tracking_figure

        arts = Artefacts()  # all or nothing
        arts.add(out / "tracking.json", json_text({
            "plant": str(plant.urdf_path), "reference": args.reference, "seconds": args.seconds,
            "after": args.after, "seed": args.seed,
            "results": {c: {n: e["metrics"] for n, e in pm.items()} for c, pm in table.items()},
        }))
        for c, pm in table.items():
            fig = tracking_figure({n: e["result"] for n, e in pm.items()}, title=c)
            arts.add(out / f"tracking_{c}.png", lambda p, fig=fig: save_figure(fig, p))
        print(wrote_line(arts.write(), out))
    return 0
