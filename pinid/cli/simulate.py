"""``pinid simulate``: the digital twin — a leg tracking a trajectory in closed loop, recorded."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from pinid.cli.common import add_robot_arguments, nonnegative_float, robot_from_args, seed_int
from pinid.errors import SpecError
from pinid.io import check_outputs
from pinid.resources import bundled_trajectories

HELP = "simulate a robot tracking a trajectory and write a recording plus its true parameters"
DESCRIPTION = """\
Reads a URDF holding the TRUE parameters and a trajectory — an excitation file from `pinid excite`, or
a preset: zha2019-1 .. zha2019-4, the Table 1 trajectories of Zha et al. 2019 (degrees, q = 0 hanging down,
mapped onto the robot's hip and knee; see docs/simulate.md).  Simulates the robot tracking it in closed
loop (PD or PID plus feed-forward, forward dynamics with Pinocchio, Coulomb and viscous friction),
adds sensor noise and encoder quantisation, and writes

  OUTPUT (.csv or .npz)    the recording in pinid's dataset format: t, q_<joint>, [dq_<joint>,] tau_<joint>
  OUTPUT.truth.json        true standard and base parameters, friction, noise levels, seed, rates
                           (name it with --truth)
  --cad-urdf FILE          with --perturb: the 'CAD' model as a URDF (the truth's kinematics and
                           friction, its inertial parameters perturbed), to identify or control with
  OUTPUT with .png         per joint: the reference and simulated position, the tracking error and
                           the measured torque (not with --no-figures)

With --base floating (docs/floating-base.md): the legs follow the excitation exactly while the pelvis hangs
in a spring-damper harness (its load cell recorded as wrench_<base link>_*), or, with --excitation gait, a
prescribed walk with force plates under the soles; the base motion is recorded as motion capture or, in the
harness only, --imu (the gait's force plates need the base position, which an IMU does not give).

The same arguments give the same files.  Defaults: 1 kHz control and sampling, 16-bit encoders plus
2e-5 rad noise, torque noise 1 % of each joint's peak, the URDF's <dynamics> friction.

examples:
  pinid simulate --urdf exo_leg --excitation exo_leg --seconds 60 --seed 1 -o data/run1.csv
  pinid simulate --urdf apal_leg --excitation zha2019-3 --seconds 20 -o data/apal3.csv --perturb 20
  pinid simulate --urdf exo_leg --excitation exo_leg -o data/run1.csv --perturb 30 --cad-urdf data/cad.urdf
  pinid simulate --urdf exo_lower_body --base floating --excitation gait --seconds 20 -o data/walk.csv
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_robot_arguments(p, base=True)
    p.add_argument(
        "--excitation",
        required=True,
        metavar="FILE|NAME|PRESET",
        help="trajectory JSON (from pinid excite), a bundled one "
        f"({', '.join(bundled_trajectories())}) or a preset: zha2019-1 .. zha2019-4",
    )
    p.add_argument(
        "--flip",
        action="append",
        default=[],
        metavar="JOINT",
        help="negate a preset's angle for JOINT (robot axis opposite to the paper's); repeatable; "
        "not with --base floating",
    )
    p.add_argument("--seconds", type=float, default=60.0, help="duration [s]; default 60")
    p.add_argument("--seed", type=seed_int, default=0, help="random seed (noise, perturbation); default 0")
    p.add_argument("-o", "--output", required=True, help="recording to write (.csv or .npz)")
    p.add_argument("--truth", default=None, help="truth JSON to write; default OUTPUT with .truth.json")
    p.add_argument("--no-figures", action="store_true", help="do not draw OUTPUT with .png (matplotlib not loaded)")
    p.add_argument(
        "--true-signals",
        default=None,
        metavar="FILE",
        help="also write the noise-free q, dq, ddq and applied torque (.csv or .npz)",
    )
    g = p.add_argument_group("rates")
    g.add_argument("--control-rate", type=float, default=1000.0, help="controller rate [Hz]; default 1000")
    g.add_argument("--sample-rate", type=float, default=None, help="recording rate [Hz]; default the control rate")
    g.add_argument(
        "--integration-rate",
        type=float,
        default=None,
        help="integration grid [Hz]; default the smallest multiple of both rates >= 2000",
    )
    g = p.add_argument_group("controller")
    g.add_argument("--controller", choices=("pd", "pid"), default="pd", help="feedback law; default pd")
    g.add_argument("--bandwidth", type=float, default=4.0, help="closed-loop bandwidth [Hz]; default 4")
    g.add_argument(
        "--feedforward",
        choices=("model", "gravity", "none"),
        default="model",
        help="feed-forward: inverse dynamics of the trajectory (model), gravity only, or none; default model",
    )
    g.add_argument(
        "--perturb",
        type=float,
        default=None,
        metavar="PERCENT",
        help="feed-forward from a 'CAD' model whose inertial parameters differ from the truth by about "
        "PERCENT %% (seeded); its parameters go into the truth JSON under 'cad'",
    )
    g.add_argument(
        "--cad-urdf",
        default=None,
        metavar="FILE",
        help="with --perturb: also write that CAD model as a URDF (inertia perturbed, friction as the truth's)",
    )
    g = p.add_argument_group("friction (true values; default the URDF's <dynamics>)")
    g.add_argument(
        "--coulomb",
        default=None,
        metavar="VALUES",
        help="Coulomb friction [N·m]: one value, one per joint (a,b) or JOINT=VALUE,...",
    )
    g.add_argument("--viscous", default=None, metavar="VALUES", help="viscous friction [N·m·s/rad], same forms")
    g.add_argument(
        "--coulomb-velocity",
        type=float,
        default=0.01,
        help="velocity scale of the simulator's tanh(dq/v_s) Coulomb model [rad/s]; default 0.01",
    )
    g = p.add_argument_group("wearer (a URDF from pinid wearer: its passive joint moments always act)")
    g.add_argument(
        "--wearer-draw",
        action="store_true",
        help="draw the true wearer away from the tables: each body's segments' mass ±25 %%, CoM ±20 %% "
        "(seeded); drawn and table values go into the truth JSON under 'wearer'",
    )
    g.add_argument(
        "--wearer-torque",
        type=nonnegative_float,
        default=0.0,
        metavar="PERCENT",
        help="the wearer's involuntary active torque: smooth random (0.2-2 Hz), per joint PERCENT %% of "
        "the RMS gravity torque along the trajectory (seeded); acts on the leg, not in the recorded torque",
    )
    g = p.add_argument_group("sensors")
    g.add_argument(
        "--position-noise", type=nonnegative_float, default=2e-5, help="position noise std [rad]; default 2e-5"
    )
    g.add_argument("--encoder-bits", type=int, default=16, help="encoder counts per turn = 2^BITS; 0: no quantisation")
    g.add_argument(
        "--torque-noise",
        default="1%",
        help="torque noise std: N·m (one value, per joint, or JOINT=VALUE) or a percentage of each "
        "joint's peak torque like 1%%; default 1%%",
    )
    g.add_argument("--record-velocity", action="store_true", help="also record velocities (true + noise)")
    g = p.add_argument_group("floating base (--base floating; docs/floating-base.md)")
    g.add_argument(
        "--imu",
        default=None,
        metavar="FRAME",
        help="record the base motion as an IMU on FRAME (a link fixed to the base) instead of motion capture "
        "(the harness only: not with --excitation gait, whose force plates need motion capture)",
    )
    g.add_argument("--wrench-noise", default="2,0.2", metavar="F,M", help="wrench noise std [N, N·m]; default 2,0.2")
    g.add_argument(
        "--imu-noise", default="0.005,0.05", metavar="G,A", help="gyro [rad/s] and accelerometer [m/s²] noise std"
    )
    g.add_argument("--velocity-noise", type=float, default=0.01, help="velocity noise std [rad/s]; default 0.01")


def _values(text: str | None, model, option: str):
    """Parse '0.5', '0.5,0.3' or 'hip=0.5,knee=0.3' into a per-joint list (or None)."""
    if text is None:
        return None
    parts = [s.strip() for s in text.split(",") if s.strip()]
    named = bool(parts) and all("=" in s for s in parts)
    try:
        if named:
            pairs = {k.strip(): float(v) for k, v in (s.split("=", 1) for s in parts)}
        else:
            vals = [float(s) for s in parts]
    except ValueError:
        raise SpecError(f"{option} {text!r}: expected numbers, e.g. 0.5 or 0.5,0.3 or hip=0.5,knee=0.3") from None
    if named:
        unknown = [k for k in pairs if k not in model.joint_names]
        if unknown:
            raise SpecError(f"{option}: joint '{unknown[0]}' is not an active joint ({', '.join(model.joint_names)})")
        missing = [j for j in model.joint_names if j not in pairs]
        if missing:
            raise SpecError(f"{option}: no value for joint(s) {missing}; give JOINT=VALUE for every joint")
        return [pairs[j] for j in model.joint_names]
    if not vals:
        raise SpecError(f"{option} {text!r}: expected numbers, e.g. 0.5 or 0.5,0.3 or hip=0.5,knee=0.3")
    if len(vals) == 1:
        return vals[0]
    if len(vals) != model.nv:
        raise SpecError(f"{option} {text!r}: {len(vals)} values for {model.nv} joints ({', '.join(model.joint_names)})")
    return vals


# pinid.simulation takes about 8 ms to import: the functions below import it when they run (deferred),
# so that pinid --help starts fast.


def _files(args: argparse.Namespace) -> dict:
    """The files of the run (:func:`pinid.simulation.outputs.write_simulation`'s arguments), checked."""
    out = Path(args.output)
    if out.suffix.lower() not in (".csv", ".npz"):
        raise SpecError(f"{out}: unknown suffix '{out.suffix}', expected .csv or .npz for the recording")
    if args.cad_urdf and args.perturb is None:
        raise SpecError("--cad-urdf needs --perturb PERCENT (the CAD model is the truth perturbed)")
    if args.true_signals and Path(args.true_signals).suffix.lower() not in (".csv", ".npz"):
        raise SpecError(f"{args.true_signals}: unknown suffix, expected .csv or .npz for --true-signals")
    return {
        "path": out,
        "truth_path": Path(args.truth) if args.truth else None,
        "true_signals": args.true_signals,
        "cad_urdf": args.cad_urdf,
        "figure": None if args.no_figures else out.with_suffix(".png"),
    }


def _torque_noise(args: argparse.Namespace, model) -> tuple:
    """--torque-noise as ``(torque_noise [N·m] or None, torque_noise_percent)`` of the twin."""
    text = args.torque_noise.strip()
    if not text.endswith("%"):
        return _values(text, model, "--torque-noise"), 1.0
    try:
        return None, float(text[:-1])
    except ValueError:
        raise SpecError(f"--torque-noise {text!r}: expected a percentage like 1% or values in N·m") from None


def run(args: argparse.Namespace) -> int:
    from pinid.simulation.outputs import simulation_paths  # deferred (see above)
    from pinid.simulation.run import Outputs, simulate_and_write

    files = _files(args)
    check_outputs(*simulation_paths(**files))  # no two on one path, none exists unless --force; creates nothing
    if args.encoder_bits < 0 or args.encoder_bits > 40:
        raise SpecError(f"--encoder-bits {args.encoder_bits}, expected 0 (no quantisation) to 40")
    model = robot_from_args(args)
    path = files.pop("path")
    outputs = Outputs(**files, command="pinid simulate " + " ".join(_argv_of(args)))
    model, options = (_floating_options if model.base == "floating" else _fixed_options)(args, model)
    text = simulate_and_write(  # warnings: one line each (main)
        model, args.excitation, path, seconds=args.seconds, seed=args.seed, **options, outputs=outputs
    )
    print(text)
    return 0


def _pair(text: str, option: str) -> tuple[float, float]:
    try:
        a, b = (float(x) for x in text.split(","))
    except ValueError:
        raise SpecError(f"{option} {text!r}: expected two numbers A,B") from None
    if not (a >= 0 and b >= 0 and np.isfinite(a + b)):
        raise SpecError(f"{option} {text!r}: expected two numbers >= 0")
    return a, b


#: Options of the fixed-base twin that the floating twin does not take (refused rather than ignored).
_FIXED_ONLY = (
    "flip",
    "perturb",
    "cad_urdf",
    "true_signals",
    "wearer_draw",
    "wearer_torque",
    "coulomb",
    "viscous",
    "record_velocity",
)


def _fixed_options(args: argparse.Namespace, model) -> tuple:
    """``(model, options)``: the model with its wearer drawn (--wearer-draw, :func:`_wearer`), the fixed-base
    twin's option groups, the wearer it carries and --flip."""
    from pinid.simulation.run import FixedBase  # deferred (see above)
    from pinid.simulation.twin import WearerLoad

    model, segments, drawn = _wearer(args, model)
    return model, {
        "flip": args.flip,
        "fixed": FixedBase(**_twin_options(args, model), perturb=args.perturb),
        "wearer": WearerLoad(segments, drawn, args.wearer_torque),
    }


def _wearer(args: argparse.Namespace, model):
    """``(model, wearer segments or None, (table, drawn) or None)``: the wearer the twin carries
    (:func:`pinid.wearer.attach.wearer_links`) and, with --wearer-draw, the model with its wearer drawn away
    from the tables (seeded by --seed) and the values it had and has."""
    from pinid.wearer.attach import wearer_links  # deferred: a robot without a wearer does not need it

    drawn = None
    if args.wearer_draw:
        from pinid.wearer.prior import draw_wearer

        table = model.inertial_parameters()
        model, values = draw_wearer(model, args.seed)
        drawn = (table, values)
    return model, (wearer_links(model.urdf_text) if model.urdf_text else None), drawn


def _floating_options(args: argparse.Namespace, model) -> tuple:
    """``(model, options)``, --base floating: the floating twin's options
    (:class:`~pinid.simulation.floating_twin.BaseSensors`); the fixed-base twin's options refused (--flip too:
    the floating twin takes the trajectory as it is)."""
    from pinid.simulation.floating_twin import BaseSensors, Noise  # deferred (see above)

    unused = [f"--{k.replace('_', '-')}" for k in _FIXED_ONLY if getattr(args, k) not in (None, False, 0.0, [])]
    if unused:
        raise SpecError(f"{', '.join(unused)}: not available with --base floating (docs/floating-base.md)")
    torque, pct = _torque_noise(args, model)
    force, moment = _pair(args.wrench_noise, "--wrench-noise")
    gyro, accel = _pair(args.imu_noise, "--imu-noise")
    noise = Noise(
        args.position_noise, 0.0 if torque is None else torque, force, moment, gyro, accel, None if torque else pct
    )
    return model, {"floating": BaseSensors(noise, args.imu, args.sample_rate or args.control_rate)}


#: Entries of the parsed namespace that do not define the run: the command and its parser, --force.
_NOT_RECORDED = ("command", "command_function", "command_parser", "force", "no_figures")


def _argv_of(args: argparse.Namespace) -> list[str]:
    """The options that define the run, for the record (paths included as given)."""
    out = []
    for k, v in sorted(vars(args).items()):
        if k in _NOT_RECORDED or v is None or v is False or v == []:
            continue
        flag = "--" + k.replace("_", "-")
        if v is True:
            out.append(flag)
        elif isinstance(v, list):
            out += [x for item in v for x in (flag, str(item))]
        else:
            out += [flag, str(v)]
    return out


def _twin_options(args: argparse.Namespace, model) -> dict:
    """The twin's option groups (rates, controller, friction, sensors) the options describe, checked."""
    from pinid.simulation.twin import Controller, Friction, Rates, Sensors  # deferred (see above)

    torque_noise, torque_pct = _torque_noise(args, model)
    return {
        "rates": Rates(args.control_rate, args.sample_rate, args.integration_rate),
        "controller": Controller(args.controller, args.bandwidth, feedforward=args.feedforward),
        "friction": Friction(
            _values(args.coulomb, model, "--coulomb"), _values(args.viscous, model, "--viscous"), args.coulomb_velocity
        ),
        "sensors": Sensors(
            args.position_noise,
            (2 * np.pi / 2**args.encoder_bits) if args.encoder_bits else 0.0,
            torque_noise,
            torque_pct,
            args.record_velocity,
            args.velocity_noise,
        ),
    }
