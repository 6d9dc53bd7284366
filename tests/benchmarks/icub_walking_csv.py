"""Convert the iCub walking recording (../shared/data/icub_walking/walking.mat, MATLAB v7.3) into pinid's
floating-base CSV format, as issue 46's author did by hand: base roll-pitch-yaw (R = Rz(yaw)·Ry(pitch)·Rx(roll))
turned into a quaternion x, y, z, w; time rebased to 0; the sole wrenches renamed ``wrench_l_sole_*`` /
``wrench_r_sole_*``; no joint torque.  Writes the first 70 % of the samples to ``train.csv`` and the last 30 % to
``val.csv`` (and the whole walk to ``walk.csv``) in the output folder, and prints the ``--joints`` list.

A benchmark helper, not part of pinid (issue 46 part 1 reads the file itself through a mapping spec):

    python tests/benchmarks/icub_walking_csv.py OUT_DIR [MAT_FILE]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

#: ``../shared/data/icub_walking`` from the project root (a worktree's root is one level deeper: /work/shared)
_DIRS = [Path(__file__).resolve().parents[k] / "shared" / "data" / "icub_walking" for k in (3, 4)]
MAT = next((d for d in _DIRS if d.is_dir()), _DIRS[0]) / "walking.mat"
URDF = MAT.parent / "iCubGenova04.urdf"
JOINTS = (
    "neck_pitch neck_roll neck_yaw torso_pitch torso_roll torso_yaw l_shoulder_pitch l_shoulder_roll "
    "l_shoulder_yaw l_elbow r_shoulder_pitch r_shoulder_roll r_shoulder_yaw r_elbow l_hip_pitch l_hip_roll "
    "l_hip_yaw l_knee l_ankle_pitch l_ankle_roll r_hip_pitch r_hip_roll r_hip_yaw r_knee r_ankle_pitch r_ankle_roll"
).split()
AXES = ("fx", "fy", "fz", "tx", "ty", "tz")


def rpy_to_quat(rpy: np.ndarray) -> np.ndarray:
    """(N, 4) quaternions x, y, z, w of R = Rz(yaw)·Ry(pitch)·Rx(roll), from (N, 3) roll, pitch, yaw [rad]."""
    r, p, y = (0.5 * rpy[:, k] for k in range(3))
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.column_stack(
        [
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
            cr * cp * cy + sr * sp * sy,
        ]
    )


def read_walk(mat: str | Path = MAT) -> dict[str, np.ndarray]:
    """The columns of the whole walk by dataset-format name (one array per column)."""
    import h5py

    with h5py.File(mat, "r") as f:
        get = {k: np.asarray(f[k], dtype=float) for k in f if not k.startswith("#") and f[k].dtype == float}
    t = get["estimatorJointsTime"].ravel()
    cols: dict[str, np.ndarray] = {"t": t - t[0]}
    for i, j in enumerate(JOINTS):
        cols[f"q_{j}"] = get["estimatorJointsPos"][i]
        cols[f"dq_{j}"] = get["estimatorJointsVel"][i]
    for k, a in enumerate("xyz"):
        cols[f"base_{a}"] = get["linkBasePos"][k]
    quat = rpy_to_quat(get["linkBaseRot"].T)
    for k, a in enumerate(("qx", "qy", "qz", "qw")):
        cols[f"base_{a}"] = quat[:, k]
    for side, var in (("l", "lfWrench"), ("r", "rfWrench")):
        for k, a in enumerate(AXES):
            cols[f"wrench_{side}_sole_{a}"] = get[var][k]
    return cols


def write(cols: dict[str, np.ndarray], path: Path, rows: slice) -> None:
    names = list(cols)
    table = np.column_stack([cols[n][rows] for n in names])
    table[:, 0] -= table[0, 0]
    np.savetxt(path, table, delimiter=",", header=",".join(names), comments="", fmt="%.10g")


def main(out: str, mat: str | Path = MAT) -> None:
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cols = read_walk(mat)
    n = len(cols["t"])
    cut = int(round(0.7 * n))
    write(cols, out / "train.csv", slice(0, cut))
    write(cols, out / "val.csv", slice(cut, n))
    write(cols, out / "walk.csv", slice(0, n))
    print(",".join(JOINTS))


if __name__ == "__main__":
    main(*sys.argv[1:])
