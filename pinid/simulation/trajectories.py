"""The trajectories the digital twin follows by name: seed 000's (Zha et al. 2019) Table 1 sine presets in
the paper's joint convention (:data:`ZHA2019_TABLE1`, :data:`PAPER_CONVENTIONS`, :func:`zha2019_trajectory`)
and the bundled Fourier trajectories; :func:`load_trajectory` reads any of them, or a trajectory JSON.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from collections.abc import Sequence

import numpy as np

from pinid.errors import SpecError
from pinid.model.robot import RobotModel
from pinid.excitation.trajectory import FourierTrajectory
from pinid.resources import EXCITATION_DIR, bundled_trajectories


#: Seed 000 (Zha et al. 2019) Table 1, degrees: (hip offset, hip sin amplitude, knee offset, knee sin
#: amplitude) of q = offset + amplitude·sin(2π t); q = 0 hanging down, counter-clockwise positive.
ZHA2019_TABLE1: dict[int, tuple[float, float, float, float]] = {
    1: (-10.0, 0.0, 45.0, -30.0),
    2: (-10.0, 0.0, 60.0, -30.0),
    3: (-30.0, -30.0, 75.0, -30.0),
    4: (-45.0, -30.0, 60.0, 30.0),
}

#: How seed 000's joint angles map onto a bundled robot's joints: (joint, sign) for hip and knee.  Angles
#: are in the paper's convention (q = 0 hanging down, counter-clockwise positive seen from the side).
#: ``apal_leg`` (seed 000's own leg): axes +y, positive = swing backward, exactly the paper's convention.
#: ``exo_leg`` (seed 001's leg): axes −y, positive hip = flexion and negative knee = flexion, so both
#: signs flip (paper hip −10° → exo_leg hip +10°; paper knee +45° → exo_leg knee −45°).
PAPER_CONVENTIONS: dict[str, tuple[tuple[str, float], tuple[str, float]]] = {
    "apal_leg": (("hip", 1.0), ("knee", 1.0)),
    "exo_leg": (("hip", -1.0), ("knee", -1.0)),
}


def trajectory_presets() -> list[str]:
    """Names of the trajectory presets: ``zha2019-1`` … ``zha2019-4`` (Zha et al. 2019, Table 1; the old
    names ``seed000-1`` … are accepted with a DeprecationWarning)."""
    return [f"zha2019-{k}" for k in ZHA2019_TABLE1]


def zha2019_trajectory(
    number: int, joints: Sequence[str] = ("hip", "knee"), signs: Sequence[float] = (1.0, 1.0)
) -> FourierTrajectory:
    """Seed 000's Table 1 trajectory ``number`` (1–4) as a Fourier trajectory (ω = 2π rad/s, one harmonic).

    ``joints``: names for (hip, knee); ``signs``: +1 or −1 per joint when the robot's axis points the other
    way than the paper's (counter-clockwise positive, q = 0 hanging down).  Angles become radians.
    """
    if isinstance(number, bool) or not isinstance(number, int) or number not in ZHA2019_TABLE1:
        raise SpecError(f"number={number!r}: seed 000 Table 1 has trajectories 1 to 4")
    ho, ha, ko, ka = ZHA2019_TABLE1[number]
    d = np.pi / 180
    s = np.asarray(signs, dtype=float)
    return FourierTrajectory(
        list(joints),
        2 * np.pi,
        s * np.array([ho, ko]) * d,
        (s * np.array([ha, ka]) * d)[:, None],
        np.zeros((2, 1)),
        meta={
            "name": f"zha2019-{number}",
            "source": "Zha et al. 2019 (seed 000), Table 1",
            "paper_degrees": {"hip": [ho, ha], "knee": [ko, ka]},
            "signs": s.tolist(),
        },
    )


def load_trajectory(spec: str, model: RobotModel, *, flip: Sequence[str] = ()) -> FourierTrajectory:
    """A trajectory for ``model`` from a JSON file (``pinid excite``), the name of one that ships with pinid
    (``seed001_table3``, :func:`pinid.resources.bundled_trajectories`) or a preset name (``zha2019-3``).

    Presets are mapped onto the model's joints named ``hip`` and ``knee`` (or, failing that, its two
    joints in order) with the signs of :data:`PAPER_CONVENTIONS` for that robot; ``flip`` negates more
    joints (the robot's axis pointing the other way).  Files must name the model's joints.
    """
    if not isinstance(spec, str):
        raise SpecError(f"spec: got {type(spec).__name__}, expected a trajectory JSON path, a bundled name or a preset")
    renamed = spec.replace("seed000-", "zha2019-", 1) if spec.startswith("seed000-") else None
    if renamed in trajectory_presets():
        warnings.warn(f"trajectory preset {spec!r} is deprecated, use {renamed!r}", DeprecationWarning, stacklevel=2)
        spec = renamed
    if spec in trajectory_presets():
        number = int(spec.split("-")[1])
        names = model.joint_names
        conv = PAPER_CONVENTIONS.get(model.name)
        if conv is not None:
            joints, signs = [c[0] for c in conv], [c[1] for c in conv]
        elif "hip" in names and "knee" in names:
            joints, signs = ["hip", "knee"], [1.0, 1.0]
        elif len(names) == 2:
            joints, signs = list(names), [1.0, 1.0]
        else:
            raise SpecError(
                f"trajectory preset {spec} is for a two-joint leg (hip, knee); {model.name} has joints "
                f"{', '.join(names)}"
            )
        for f in flip:
            if f not in joints:
                raise SpecError(f"--flip {f}: not a joint of the preset (its joints: {', '.join(joints)})")
        signs = [-s if j in flip else s for j, s in zip(joints, signs)]
        if len(names) != 2:
            raise SpecError(
                f"trajectory preset {spec} moves two joints; {model.name} has {len(names)} active joints "
                f"({', '.join(names)}); lock the others with --lock"
            )
        return zha2019_trajectory(number, joints, signs)
    p = Path(spec)
    if not p.exists() and spec in bundled_trajectories():
        p = EXCITATION_DIR / f"{spec}.json"
    if not p.exists():
        raise SpecError(
            f"{spec}: no such excitation file, and not a bundled trajectory "
            f"({', '.join(bundled_trajectories())}) or a preset ({', '.join(trajectory_presets())})"
        )
    tr = FourierTrajectory.load(p)
    if flip:
        raise SpecError("--flip applies to trajectory presets only; an excitation file is in the URDF's convention")
    return tr
