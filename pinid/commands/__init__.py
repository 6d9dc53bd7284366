"""Subcommands of the ``pinid`` command, one module each (see :mod:`pinid.cli`)."""

from __future__ import annotations

import argparse

from ..regressor import JointTerms


def add_robot_arguments(p: argparse.ArgumentParser, *, default: str | None = "exo_leg") -> None:
    """The options every command uses to choose a robot: --urdf, --joints, --lock."""
    p.add_argument("--urdf", default=default, required=default is None,
                   help="URDF file, bundled robot (exo_leg, apal_leg) or example-robot-data name (panda, ur5, "
                        f"double_pendulum){'' if default is None else f'; default {default}'}")
    p.add_argument("--joints", default=None, help="comma-separated active joints (default: all movable, unlocked)")
    p.add_argument("--lock", action="append", default=[], metavar="JOINT=VALUE",
                   help="hold a joint fixed at VALUE [rad or m]; repeatable")


def add_terms_argument(p: argparse.ArgumentParser) -> None:
    """The --terms option: which joint terms enter the model."""
    p.add_argument("--terms", default="fc,fv",
                   help="joint terms in the model, comma-separated from fc (Coulomb), fv (viscous), "
                        "offset (constant torque), armature (rotor inertia); 'none' for none; default fc,fv")


def robot_from_args(args: argparse.Namespace):
    """Load the RobotModel the robot options describe."""
    from ..errors import SpecError
    from ..model import RobotModel

    locked = {}
    for item in args.lock:
        name, sep, value = item.partition("=")
        try:
            if not sep:
                raise ValueError
            locked[name.strip()] = float(value)
        except ValueError:
            raise SpecError(f"--lock {item!r}: expected JOINT=VALUE with a number, e.g. --lock knee=-0.5") from None
    joints = [j.strip() for j in args.joints.split(",") if j.strip()] if args.joints else None
    return RobotModel.from_urdf(args.urdf, joints=joints, locked=locked)


def terms_from_args(args: argparse.Namespace) -> JointTerms:
    """The JointTerms the --terms option describes."""
    from ..errors import SpecError

    try:
        return JointTerms.from_names(args.terms)
    except ValueError as exc:
        raise SpecError(f"--terms: {exc}") from None
