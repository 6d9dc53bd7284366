"""``pinid wearer``: an exoskeleton URDF with the wearer's thigh and shank (and foot) strapped to it."""

from __future__ import annotations

import argparse
from pathlib import Path

from pinid.io import Artefacts, display_path

HELP = "add a wearer's leg segments (anthropometric tables) to an exoskeleton URDF"
DESCRIPTION = """\
Reads an exoskeleton URDF and a wearer's body mass, height and sex, takes the mass, centre of mass
and radii of gyration of the thigh, shank and foot from de Leva 1996 (pinid/resources/anthropometry/
de_leva_1996.toml; lengths scale with height), and writes the URDF with each human segment as a link
fixed to the exo link it is strapped to: proximal endpoint at the joint centre, segment axis along the
exo link, transverse axis along the joint axis (see docs/wearer.md).  A foot strapped to the shank's
link (no ankle joint) starts at the ankle and points forward.  The default --attach adds the thigh and
shank; add knee:foot for the foot.  On exo_lower_body (two legs and a pelvis) the default attaches the
pelvis (de Leva's lower trunk) to the pelvis frame and each leg's thigh, shank and foot to its hip
flexion, knee and ankle links: pelvis:pelvis,l_hip_flexion:l_thigh,l_knee:l_shank,l_ankle:l_foot,
r_hip_flexion:r_thigh,r_knee:r_shank,r_ankle:r_foot.  The result loads with a fixed or a floating base.

  OUTPUT    the URDF: the exo's links unchanged, plus links wearer_<segment> and fixed joints
            wearer_<segment>_strap
  OUTPUT with .png  where the segments attach: the robot in its zero pose (sagittal view, and frontal
            for a 3-D robot), each segment, the exo link frame it is strapped to and its CoM
            (not with --no-figures)

Body mass 40-150 kg and height 1.40-2.10 m (the range pinid accepts for the table's proportional scaling).

examples:
  pinid wearer --urdf exo_leg --mass 75 --height 1.78 --sex male --attach hip:thigh,knee:shank -o exo_with_wearer.urdf
  pinid wearer --urdf exo_lower_body --mass 75 --height 1.78 --sex male -o exo_lower_body_worn.urdf
"""


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--urdf", default="exo_leg", help="exoskeleton URDF file or bundled robot name; default exo_leg")
    p.add_argument("--mass", type=float, required=True, help="wearer's body mass [kg]")
    p.add_argument("--height", type=float, required=True, help="wearer's height (stature) [m]")
    p.add_argument("--sex", choices=("male", "female"), required=True, help="which de Leva table to use")
    p.add_argument(
        "--attach",
        default=None,
        help="POINT:SEGMENT pairs, comma-separated: POINT an exo joint (its child link) or link, "
        "SEGMENT pelvis, thigh, shank or foot (with two legs: l_thigh … r_foot); default: the robot's "
        "(exo_lower_body: the pelvis and both legs' thigh, shank and foot), else hip:thigh,knee:shank",
    )
    p.add_argument("-o", "--output", required=True, metavar="FILE", help="URDF to write")
    p.add_argument("--no-figures", action="store_true", help="do not draw OUTPUT with .png (matplotlib not loaded)")


def run(args: argparse.Namespace) -> int:
    # deferred: ~4 ms that pinid --help would pay
    from pinid.wearer.attach import attachment_png, wearer_links, wearer_urdf

    arts = Artefacts()  # checked before the work, written all or nothing
    arts.add(args.output, lambda p: p.write_text(text, encoding="utf-8"))
    figure = None if args.no_figures else Path(args.output).with_suffix(".png")
    if figure is not None:
        arts.add(figure, lambda p: p.write_bytes(attachment_png(text)))
    arts.check()
    text = wearer_urdf(args.urdf, args.attach, mass=args.mass, height=args.height, sex=args.sex)
    arts.write()
    for seg, (link, m, c, _) in wearer_links(text).items():
        print(f"{seg:6s} on {link}: {m:.2f} kg, CoM ({c[0]:+.3f}, {c[1]:+.3f}, {c[2]:+.3f}) m")
    print(f"wrote {display_path(args.output)}")
    if figure is not None:
        print(f"wrote {display_path(figure)} (where the segments attach: zero pose, attachment frames, CoMs)")
    return 0
