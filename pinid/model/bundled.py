"""Where robot descriptions come from: a file path, a URDF bundled with pinid, or example-robot-data.

``resolve_robot("exo_leg")`` finds ``urdf/exo_leg.urdf``; ``resolve_robot("panda")`` finds the Panda of
example-robot-data with its fingers locked.  Any existing path is used as it is.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import metadata
from pathlib import Path

from pinid.errors import ModelError
from pinid.resources import URDF_DIR

#: Folder of the URDFs that ship with pinid (the repository's top-level ``urdf/``).
BUNDLED_URDF_DIR = URDF_DIR


@dataclass(frozen=True)
class RobotPreset:
    """A named robot: a URDF path inside example-robot-data and the joints to lock [rad or m]; None holds a
    joint at 0, or at the middle of its range when 0 is outside it."""

    subpath: str
    locked: dict[str, float | None] = field(default_factory=dict)


#: Robots of example-robot-data known by a short name.
EXAMPLE_ROBOTS: dict[str, RobotPreset] = {
    "panda": RobotPreset("panda_description/urdf/panda.urdf", {"panda_finger_joint1": 0.0, "panda_finger_joint2": 0.0}),
    "ur3": RobotPreset("ur_description/urdf/ur3_robot.urdf"),
    "ur5": RobotPreset("ur_description/urdf/ur5_robot.urdf"),
    "ur10": RobotPreset("ur_description/urdf/ur10_robot.urdf"),
    "double_pendulum": RobotPreset("double_pendulum_description/urdf/double_pendulum.urdf"),
    "z1": RobotPreset("z1_description/urdf/z1.urdf"),
    # legged robots, meant for --base floating (docs/floating-base.md)
    "talos_legs": RobotPreset(
        "talos_data/robots/talos_reduced.urdf",
        {
            n: None
            for n in ["torso_1_joint", "torso_2_joint", "head_1_joint", "head_2_joint"]
            + [f"arm_{s}_{i}_joint" for s in ("left", "right") for i in range(1, 8)]
            + [f"gripper_{s}_joint" for s in ("left", "right")]
        },
    ),
    "solo12": RobotPreset("solo_description/robots/solo12.urdf"),
    "anymal": RobotPreset("anymal_b_simple_description/robots/anymal.urdf"),
}


@lru_cache(maxsize=1)
def example_robot_data_dir() -> Path:
    """The ``robots/`` folder of the installed example-robot-data (4.x with a loader, or 5.x/6.x without)."""
    candidates: list[Path] = []
    env = os.environ.get("EXAMPLE_ROBOT_DATA_MODEL_DIR")
    if env:
        candidates.append(Path(env))
    try:
        dist = metadata.distribution("example-robot-data")
        for f in dist.files or ():
            parts = Path(str(f)).parts
            if "robots" in parts:
                head = Path(*parts[: parts.index("robots") + 1])
                candidates.append(Path(dist.locate_file(head)))
                break
    except metadata.PackageNotFoundError:
        pass
    try:  # example-robot-data 4.x ships a loader that knows its folder
        from example_robot_data.robots_loader import getModelPath  # type: ignore

        candidates.append(Path(getModelPath("panda_description/urdf/panda.urdf")) / "example-robot-data" / "robots")
        candidates.append(Path(getModelPath("panda_description/urdf/panda.urdf")))
    except Exception:  # noqa: BLE001 - any failure just means "not this way"
        pass
    for c in candidates:
        if (c / "panda_description").is_dir():
            return c
    raise ModelError("example-robot-data: robots folder not found; expected the package 'example-robot-data' installed")


def resolve_robot(name_or_path: str | os.PathLike) -> tuple[Path, dict[str, float]]:
    """Return ``(urdf_path, locked_joints)`` for a path, a bundled name (``exo_leg``) or a preset (``panda``)."""
    p = Path(name_or_path)
    if p.exists():
        return p, {}
    name = str(name_or_path)
    bundled = BUNDLED_URDF_DIR / f"{name}.urdf"
    if bundled.is_file():
        return bundled, {}
    if name in EXAMPLE_ROBOTS:
        preset = EXAMPLE_ROBOTS[name]
        return example_robot_data_dir() / preset.subpath, dict(preset.locked)
    known = sorted({f.stem for f in BUNDLED_URDF_DIR.glob("*.urdf")} | set(EXAMPLE_ROBOTS))
    raise ModelError(f"{name}: no such URDF file, and not a known robot name (known: {', '.join(known)})")
