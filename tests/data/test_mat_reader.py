"""MATLAB recordings read as a lab saves them (issue 46): v5 (SciPy) and v7.3 (HDF5, h5py) files through a
mapping spec — variables by name, signals in rows or columns, roll-pitch-yaw orientation, rebased Unix time —
give the signals and the identification of the dataset-format file; bad input is one line, exit 2."""

from __future__ import annotations

import sys

import numpy as np
import pytest
from scipy.io import savemat
from scipy.spatial.transform import Rotation

from conftest import assert_clean_error, run_cli

from pinid import RobotModel
from pinid.data.formats import read_recording, write_recording
from pinid.data.mapping import rpy_to_quaternion
from pinid.data.mat_reader import mat_version
from pinid.errors import DataError
from pinid.identification.run import identify
from pinid.identification.study import Study
from pinid.simulation.floating_twin import simulate_gait

EXO = ["--urdf", "exo_lower_body", "--base", "floating"]
EPOCH = 1629990470.25  # Unix time of the first sample, as a lab's logger writes it
PLATE = ("fx", "fy", "fz", "copx", "copy", "copz", "tz")


def write_v73(path, variables: dict) -> None:
    """A MATLAB v7.3-like file: HDF5 with MATLAB's 512-byte user block (its text header), each variable a
    dataset of the column-major array (h5py shows MATLAB's r × c as c × r) with its MATLAB_class."""
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w", userblock_size=512) as f:
        for name, a in variables.items():
            a = np.atleast_2d(np.asarray(a, dtype=float))
            f.create_dataset(name, data=a.T).attrs["MATLAB_class"] = np.bytes_(b"double")
    with open(path, "r+b") as f:
        f.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Wed Sep 22 16:36:19 2021 HDF5 schema 1.00 .")


@pytest.fixture(scope="module")
def exo():
    return RobotModel.from_urdf("exo_lower_body", base="floating")


@pytest.fixture(scope="module")
def walk(exo, tmp_path_factory):
    """The gait twin (3 s at 100 Hz) as a dataset-format CSV, and its MATLAB variables as a lab would save them:
    one signal per row (nj × N), the orientation as roll, pitch, yaw, Unix time stamps."""
    folder = tmp_path_factory.mktemp("mat")
    rec = simulate_gait(exo, seconds=3, rate=100).recording
    write_recording(folder / "walk.csv", rec)
    rec = read_recording(folder / "walk.csv", model=exo)  # the numbers as written, to compare with
    cols = rec.floating.columns()
    quat = np.column_stack([cols[f"base_q{k}"] for k in "xyzw"])
    yaw, pitch, roll = Rotation.from_quat(quat).as_euler("ZYX").T
    variables = {
        "time": EPOCH + rec.t[None, :],
        "jointPos": rec.q.T,
        "jointTorque": rec.tau.T,
        "basePos": np.vstack([cols[f"base_{k}"] for k in "xyz"]),
        "baseRot": np.vstack([roll, pitch, yaw]),
        **{f"{s}Plate": np.vstack([cols[f"plate_{s}_sole_{k}"] for k in PLATE]) for s in "lr"},
        **{f"{s}Contact": cols[f"contact_{s}_sole"][None, :] for s in "lr"},
    }
    lines = ['time = { column = "time", rebase = true }']
    for i, j in enumerate(rec.joints):
        lines += [f"[joints.{j}]", f'q = {{ column = "jointPos", index = {i} }}']
        lines += [f'tau = {{ column = "jointTorque", index = {i} }}']
    lines += ["[floating]"]
    lines += [f'base_{k} = {{ column = "basePos", index = {i} }}' for i, k in enumerate("xyz")]
    lines += [f'base_{k} = {{ column = "baseRot", index = {i} }}' for i, k in enumerate(("roll", "pitch", "yaw"))]
    for s in "lr":
        lines += [f'plate_{s}_sole_{k} = {{ column = "{s}Plate", index = {i} }}' for i, k in enumerate(PLATE)]
        lines += [f'contact_{s}_sole = "{s}Contact"']
    (folder / "map.toml").write_text("\n".join(lines) + "\n")
    return folder, rec, variables


def _same(a, b):
    np.testing.assert_allclose(b.t, a.t, rtol=0, atol=1e-6)  # rebased Unix time: 0.24 µs resolution at 1.6e9 s
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-14)
    np.testing.assert_allclose(b.tau, a.tau, rtol=0, atol=1e-14)
    ca, cb = a.floating.columns(), b.floating.columns()
    assert sorted(ca) == sorted(cb)
    for name in ca:
        np.testing.assert_allclose(cb[name], ca[name], rtol=0, atol=1e-12, err_msg=name)


@pytest.mark.parametrize("layout", ["v5 rows", "v5 columns", "v7.3 rows", "v7.3 columns"])
def test_mat_file_reads_as_the_dataset_format(exo, walk, layout, tmp_path):
    """Every layout — v5 or v7.3, signals in rows or in columns — gives the dataset-format file's samples: time
    rebased from Unix time, the quaternion from roll-pitch-yaw."""
    folder, rec, variables = walk
    if layout.endswith("columns"):
        variables = {k: v.T for k, v in variables.items()}
    path = tmp_path / "walk.mat"
    if layout.startswith("v5"):
        savemat(path, variables)
        assert mat_version(path) == "5"
    else:
        write_v73(path, variables)
        assert mat_version(path) == "7.3"
    _same(rec, read_recording(path, model=exo, mapping=folder / "map.toml"))


def test_mat_file_identifies_as_the_dataset_format(exo, walk, tmp_path):
    """The identification from the v7.3 file equals the dataset-format file's (the same samples), and the
    command line reads it."""
    folder, rec, variables = walk
    # time from 0 here: Unix time stamps carry 0.24 µs of rounding, which moves the barely excited parameters
    write_v73(tmp_path / "walk.mat", variables | {"time": rec.t[None, :]})
    (tmp_path / "map.toml").write_text((folder / "map.toml").read_text())
    r = {
        path: identify(Study(exo, path, mapping=m), methods=("ols",)).results["ols"].base
        for path, m in ((folder / "walk.csv", None), (tmp_path / "walk.mat", tmp_path / "map.toml"))
    }
    np.testing.assert_allclose(r[tmp_path / "walk.mat"], r[folder / "walk.csv"], rtol=1e-6, atol=1e-8)
    assert r[tmp_path / "walk.mat"][0] == pytest.approx(21.8, rel=0.01)  # the total mass
    proc = run_cli("identify", *EXO, "--data", "walk.mat", "--mapping", "map.toml", "--methods", "ols",
                   "--no-report", "-o", "res", cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "res" / "identification.json").is_file()


def test_yaw_wrapping_at_pi_gives_a_continuous_quaternion():
    """A yaw that wraps from +π to −π is the same rotation: the quaternion has no jump (its sign is kept
    continuous), and each sample is R = Rz(yaw)·Ry(pitch)·Rx(roll)."""
    t = np.linspace(0, 2, 201)
    yaw = np.angle(np.exp(1j * (2.5 + 1.5 * t)))  # crosses π at t ≈ 0.43: wraps to −π
    roll, pitch = 0.1 * np.sin(3 * t), 0.2 * np.cos(2 * t)
    assert np.max(np.abs(np.diff(yaw))) > 6  # it does wrap
    q = rpy_to_quaternion(roll, pitch, yaw)
    assert np.max(np.linalg.norm(np.diff(q, axis=0), axis=1)) < 0.02  # continuous
    R = Rotation.from_euler("ZYX", np.column_stack([yaw, pitch, roll])).as_matrix()
    np.testing.assert_allclose(Rotation.from_quat(q).as_matrix(), R, atol=1e-12)


def test_non_uniform_time_stamps_are_resampled(exo, walk, tmp_path):
    """Time stamps 8.4–11.4 ms apart (as on the iCub) are read as they are (rebased) and resampled onto a uniform
    grid at the median rate before filtering (pinid.data.preprocess, the jitter rule)."""
    from pinid.data.preprocess import prepare

    folder, rec, variables = walk
    n = rec.n
    steps = 0.01 + 0.0015 * np.sin(np.arange(n - 1) * 1.3)  # 8.5–11.5 ms
    t = np.r_[0.0, np.cumsum(steps)]
    savemat(tmp_path / "walk.mat", variables | {"time": EPOCH + t[None, :]})
    ds = read_recording(tmp_path / "walk.mat", model=exo, mapping=folder / "map.toml")
    np.testing.assert_allclose(ds.t, t, atol=1e-6)
    step = np.diff(prepare(ds).data.t)  # the floating recording prepared: joints, base and plates on one grid
    assert np.ptp(step) < 1e-12 and step[0] == pytest.approx(np.median(steps), rel=1e-4)  # Unix time: 0.24 µs


def _spec(tmp_path, time='time = { column = "time", rebase = true }', q='{ column = "jointPos", index = 0 }'):
    lines = [time] + [
        f"[joints.{j}]\nq = {q if i == 0 else f'{{ column = {chr(34)}jointPos{chr(34)}, index = {i} }}'}"
        for i, j in enumerate(("l_hip_abduction", "l_hip_flexion", "l_knee", "l_ankle"))
    ]
    (tmp_path / "map.toml").write_text("\n".join(lines) + "\n")


@pytest.mark.parametrize(
    "change, spec, words",
    [
        ({}, {"q": '{ column = "jointPos" }'}, ["'jointPos'", "holds 4 signals", "expected index = 0 … 3"]),
        ({}, {"q": '{ column = "jointPos", index = 7 }'}, ["'jointPos'", "index = 7 is out of range"]),
        (
            {},
            {"q": '{ column = "jointPoss", index = 0 }'},
            ["'jointPoss'", "not in the file", "did you mean 'jointPos'"],
        ),
        ({"jointPos": np.zeros((4, 250))}, {}, ["'jointPos'", "size 4×250", "time 'time' has 300 samples"]),
        ({"time": np.zeros((2, 300))}, {}, ["'time'", "size 2×300", "expected a vector of time stamps"]),
        ({"jointPos": np.zeros((4, 300, 2))}, {}, ["'jointPos'", "size 4×300×2", "expected a vector or a matrix"]),
        ({"jointPos": "abc"}, {}, ["'jointPos'", "is a MATLAB char", "expected a numeric array"]),
    ],
    ids=["no index", "index out of range", "missing", "length", "time shape", "3-D", "char"],
)
@pytest.mark.parametrize("version", ["5", "7.3"])
def test_bad_mat_variable_is_one_line_and_writes_nothing(change, spec, words, version, tmp_path):
    """A variable missing, of the wrong shape or type, or whose length differs from the time's: one line naming
    it and what was expected, exit status 2, nothing written."""
    t = np.arange(300) * 0.01
    variables = {"time": EPOCH + t[None, :], "jointPos": 0.1 * np.ones((4, 300))} | change
    if version == "5":
        savemat(tmp_path / "run.mat", variables)
    else:
        if isinstance(variables["jointPos"], str):
            pytest.skip("a char variable is written by the v5 writer only")
        write_v73(tmp_path / "run.mat", variables)
    _spec(tmp_path, **spec)
    joints = "l_hip_abduction,l_hip_flexion,l_knee,l_ankle"
    proc = run_cli("identify", "--urdf", "exo_lower_body", "--joints", joints, "--data", "run.mat", "--mapping",
                   "map.toml", "-o", "out", cwd=tmp_path)  # fmt: skip
    assert_clean_error(proc, *words)
    assert not (tmp_path / "out").exists()


def test_v73_without_h5py_names_the_extra(monkeypatch, tmp_path):
    """A v7.3 file without h5py installed: one line naming the optional extra, exit 2, nothing written."""
    write_v73(tmp_path / "run.mat", {"time": np.arange(10)[None, :] * 0.01, "jointPos": np.zeros((4, 10))})
    _spec(tmp_path)
    monkeypatch.setitem(sys.modules, "h5py", None)  # import h5py raises ImportError
    with pytest.raises(DataError, match=r"v7\.3 file \(HDF5\) needs h5py"):
        read_recording(tmp_path / "run.mat", mapping=tmp_path / "map.toml")
    proc = run_cli("identify", "--urdf", "exo_lower_body", "--joints", "l_hip_abduction,l_hip_flexion,l_knee,l_ankle",
                   "--data", "run.mat", "--mapping", "map.toml", "-o", "out", cwd=tmp_path)  # fmt: skip
    assert_clean_error(proc, "run.mat", "needs h5py", "pinid[mat]")
    assert not (tmp_path / "out").exists()


def test_rpy_and_quaternion_together_are_refused(exo, tmp_path):
    from pinid.errors import SpecError

    (tmp_path / "map.toml").write_text(
        'time = "t"\n[joints.l_knee]\nq = "k"\n[floating]\nbase_roll = "r"\nbase_pitch = "p"\nbase_yaw = "y"\n'
        'base_qw = "w"\n'
    )
    (tmp_path / "d.csv").write_text("t,k,r,p,y,w\n0,0,0,0,0,1\n0.01,0,0,0,0,1\n")
    with pytest.raises(SpecError, match="both give the orientation"):
        read_recording(tmp_path / "d.csv", model=exo, mapping=tmp_path / "map.toml")
    (tmp_path / "map.toml").write_text('time = "t"\n[joints.l_knee]\nq = "k"\n[floating]\nbase_roll = "r"\n')
    with pytest.raises(SpecError, match="without base_pitch, base_yaw"):
        read_recording(tmp_path / "d.csv", model=exo, mapping=tmp_path / "map.toml")


def test_unrecorded_joints_error_gives_the_line_to_copy(tmp_path):
    """A robot with more joints than the recording: the error prints the --joints line of the recorded ones (in
    the model's order) and the --lock line of the others; the --joints line copied runs."""
    t = np.arange(300) * 0.01
    savemat(tmp_path / "run.mat", {"time": EPOCH + t[None, :], "jointPos": 0.1 * np.ones((4, 300))})
    _spec(tmp_path)
    proc = run_cli("identify", "--urdf", "exo_lower_body", "--data", "run.mat", "--mapping", "map.toml", "-o", "out",
                   cwd=tmp_path)  # fmt: skip
    line = "--joints l_hip_abduction,l_hip_flexion,l_knee,l_ankle "
    assert_clean_error(
        proc, "no data for joint 'r_hip_abduction'", line, "--lock r_hip_abduction=0 --lock r_hip_flexion=0"
    )
    joints = proc.stderr.split("--joints ")[1].split()[0]
    proc = run_cli("info", "--urdf", "exo_lower_body", "--joints", joints, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
