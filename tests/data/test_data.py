"""Recordings: the dataset format, mapping specs, checks, and the CLI's clean errors on bad data."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from conftest import assert_clean_error, load, run_cli
from pinid.errors import DataWarning
from pinid.data.formats import format_spec, read_recording, write_recording
from pinid.data.dataset import Dataset
from pinid.errors import DataError, SpecError
from pinid.data.mapping import MappingSpec

FS = 200.0


def leg_data(n: int = 1000, fs: float = FS, joints=("hip", "knee")) -> Dataset:
    """A smooth recording inside exo_leg's limits (hip [-0.087, 1.309], knee [-1.658, -0.087])."""
    t = np.arange(n) / fs
    w = 2 * np.pi * 0.5
    q = np.column_stack([0.6 + 0.3 * np.sin(w * t), -0.9 + 0.3 * np.sin(w * t + 1.0)])
    dq = np.column_stack([0.3 * w * np.cos(w * t), 0.3 * w * np.cos(w * t + 1.0)])
    tau = np.column_stack([10 * np.sin(q[:, 0]) + 2 * dq[:, 0], 3 * np.sin(q[:, 1]) + dq[:, 1]])
    return Dataset(t=t, q=q, joints=list(joints), dq=dq, tau=tau)


def write_csv(path: Path, header: list[str], rows: np.ndarray, fmt: str = "%.10g") -> Path:
    lines = [",".join(header)] + [",".join(fmt % v for v in r) for r in rows]
    path.write_text("\n".join(lines) + "\n")
    return path


# ---------------------------------------------------------------------------------------------- format
@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_round_trip_and_reorder(tmp_path, suffix):
    ds = leg_data()
    p = write_recording(tmp_path / f"rec{suffix}", ds)
    back = read_recording(p)
    assert back.joints == ["hip", "knee"]
    tol = 0 if suffix == ".npz" else 1e-11
    for name in ("t", "q", "dq", "tau"):
        np.testing.assert_allclose(getattr(back, name), getattr(ds, name), rtol=tol, atol=tol)
    assert back.ddq is None
    # columns put in the model's order
    swapped = Dataset(t=ds.t, q=ds.q[:, ::-1], joints=["knee", "hip"], tau=ds.tau[:, ::-1])
    write_recording(tmp_path / f"sw{suffix}", swapped)
    back = read_recording(tmp_path / f"sw{suffix}", model=load("exo_leg"))
    assert back.joints == ["hip", "knee"]
    np.testing.assert_allclose(back.q, ds.q, atol=1e-11)


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_write_is_deterministic(tmp_path, suffix):
    ds = leg_data(300)
    a = write_recording(tmp_path / f"a{suffix}", ds).read_bytes()
    b = write_recording(tmp_path / f"b{suffix}", ds).read_bytes()
    assert a == b
    assert not list(tmp_path.glob(".*.part"))


def test_header_and_ignored_columns(tmp_path):
    ds = leg_data(50)
    rows = np.column_stack([ds.t, ds.q, ds.tau, np.ones(50)])
    p = write_csv(tmp_path / "x.csv", ["t", "q_hip", "q_knee", "tau_hip", "tau_knee", "temperature"], rows)
    back = read_recording(p)
    assert back.meta["ignored_columns"] == ["temperature"]
    assert back.dq is None and back.tau is not None
    spec, ignored = format_spec(["t", "q_a_b", "dq_a_b", "ddq_a_b", "tau_a_b"])
    assert spec["joints"] == {"a_b": {"q": "q_a_b", "dq": "dq_a_b", "ddq": "ddq_a_b", "tau": "tau_a_b"}} and not ignored


def test_format_errors(tmp_path):
    p = write_csv(tmp_path / "x.csv", ["time", "q_hip"], np.ones((3, 2)))
    with pytest.raises(DataError, match=r"no column 't' \(it has 'time'"):
        read_recording(p)
    p = write_csv(tmp_path / "y.csv", ["t", "q_hip", "tau_knee"], np.ones((3, 3)))
    with pytest.raises(DataError, match="'tau_knee' has no position column 'q_knee'"):
        read_recording(p)
    p = write_csv(tmp_path / "z.csv", ["t", "q_hip", "q_knee", "tau_hip"], np.ones((3, 4)))
    with pytest.raises(DataError, match=r"tau given for joints \[.hip.\] but not for \[.knee.\]"):
        read_recording(p)
    (tmp_path / "w.xlsx").write_text("x")
    with pytest.raises(DataError, match="unknown file type '.xlsx'"):
        read_recording(tmp_path / "w.xlsx")
    (tmp_path / "e.csv").write_text("")
    with pytest.raises(DataError, match="file is empty"):
        read_recording(tmp_path / "e.csv")
    p = write_csv(tmp_path / "n.csv", ["0", "1"], np.ones((3, 2)))
    with pytest.raises(DataError, match="the first line is numbers, not column names"):
        read_recording(p)
    with pytest.raises(DataError, match="file not found"):
        read_recording(tmp_path / "missing.csv")


# ---------------------------------------------------------------------------------------------- mapping specs
def test_mapping_degrees_currents_no_header_rate_rows(tmp_path):
    ds = leg_data(400)
    gain = 0.25  # N·m per A
    raw = np.column_stack([np.degrees(ds.q[:, 0]), -ds.q[:, 1], ds.tau[:, 0] / gain, ds.tau[:, 1]])
    p = tmp_path / "rig.txt"
    p.write_text("# logged by the rig\n" + "\n".join(" ".join(f"{v:.12g}" for v in r) for r in raw) + "\n")
    spec = {
        "header": False,
        "delimiter": "whitespace",
        "time": {"rate": FS},
        "rows": [100, 300],
        "joints": {
            "hip": {"q": {"column": 0, "scale": "deg"}, "tau": {"column": 2, "scale": gain}},
            "knee": {"q": {"column": 1, "sign": -1}, "tau": 3},
        },
    }
    back = read_recording(p, mapping=spec, model=load("exo_leg"))
    np.testing.assert_allclose(back.t, ds.t[100:300], atol=1e-12)
    np.testing.assert_allclose(back.q, ds.q[100:300], atol=1e-10)
    np.testing.assert_allclose(back.tau, ds.tau[100:300], atol=1e-9)
    # named columns of a headerless file, and a TOML file
    toml = tmp_path / "spec.toml"
    toml.write_text(
        'header = false\ndelimiter = "whitespace"\nnames = ["a", "b", "c", "d"]\ntime = { rate = 200.0 }\n'
        '[joints.hip]\nq = { column = "a", scale = "deg" }\n[joints.knee]\nq = { column = "b", sign = -1 }\n'
    )
    back = read_recording(p, mapping=toml)
    np.testing.assert_allclose(back.q, ds.q, atol=1e-10)


def test_mapping_separate_files_and_own_time(tmp_path):
    ds = leg_data(400)
    write_csv(tmp_path / "run_pos.csv", ["time_ms", "p1", "p2"], np.column_stack([1000 * ds.t, ds.q]))
    write_csv(tmp_path / "run_pos_tau.csv", ["t1", "t2"], ds.tau)
    spec = {
        "time": {"column": "time_ms", "scale": "ms"},
        "sources": {"torque": {"path": "{stem}_tau.csv"}},
        "joints": {
            "hip": {"q": "p1", "tau": {"source": "torque", "column": "t1"}},
            "knee": {"q": "p2", "tau": {"source": "torque", "column": 1}},
        },
    }
    back = read_recording(tmp_path / "run_pos.csv", mapping=spec)
    np.testing.assert_allclose(back.tau, ds.tau, atol=1e-9)
    # torques at their own (slower) rate, interpolated onto the positions' time
    sl = slice(None, None, 4)
    write_csv(tmp_path / "slow.csv", ["ts", "t1", "t2"], np.column_stack([ds.t[sl], ds.tau[sl]]))
    spec["sources"]["torque"] = {"path": "slow.csv", "time": "ts"}
    spec["joints"]["knee"]["tau"] = {"source": "torque", "column": 2}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        back = read_recording(tmp_path / "run_pos.csv", mapping=spec)
    assert back.t[-1] <= ds.t[sl][-1] + 1e-12  # samples after the torque file's end are dropped ...
    assert any("inside every source's time span" in str(w.message) for w in caught)  # ... and said so
    k = np.searchsorted(ds.t, back.t)
    np.testing.assert_allclose(back.tau, ds.tau[k], atol=0.02 * np.abs(ds.tau).max())


def test_mapping_motor_side_with_coupling(tmp_path):
    ds = leg_data(300)
    R = np.array([[50.0, 0.0], [-50.0, 50.0]])  # q_motor = R q_joint (a differential, as on a wrist)
    qm = ds.q @ R.T
    taum = np.linalg.solve(R.T, ds.tau.T).T  # tau_joint = R^T tau_motor
    counts = 2 * np.pi / 4096
    np.savez(tmp_path / "motors.npz", t=ds.t, enc=np.round(qm / counts), cur=taum / 0.1)
    spec = {
        "time": "t",
        "transmission": {"joints": ["hip", "knee"], "motors": ["m1", "m2"], "matrix": R.tolist()},
        "motors": {
            "m1": {
                "q": {"column": "enc", "index": 0, "scale": counts},
                "tau": {"column": "cur", "index": 0, "scale": 0.1},
            },
            "m2": {
                "q": {"column": "enc", "index": 1, "scale": counts},
                "tau": {"column": "cur", "index": 1, "scale": 0.1},
            },
        },
    }
    back = read_recording(tmp_path / "motors.npz", mapping=spec, model=load("exo_leg"))
    np.testing.assert_allclose(back.tau, ds.tau, atol=1e-9)
    np.testing.assert_allclose(back.q, ds.q, atol=counts / 25)  # encoder counts divided by the reduction


@pytest.mark.parametrize(
    "spec, message",
    [
        (
            {"time": "t", "joints": {"hip": {"q": {"colum": "q_hip"}}}},
            "unknown key 'colum' in [joints.hip.q] (did you mean 'column'?)",
        ),
        ({"time": "t", "joints": {"hip": {"q": "q_hipp"}}}, "column 'q_hipp' is not in x.csv (did you mean 'q_hip'?)"),
        ({"joints": {"hip": {"q": "q_hip"}}}, "no time"),
        (
            {"time": "t", "joints": {"hip": {"q": {"column": "q_hip", "source": "other"}}}},
            "source = 'other' is not defined",
        ),
        (
            {"time": "t", "joints": {"hip": {"q": {"column": "q_hip", "scale": "furlong"}}}},
            "expected a finite number or one of",
        ),
        ({"time": "t", "joints": {"hip": {"q": {"column": "q_hip", "sign": 2}}}}, "sign = 2, expected 1 or -1"),
        ({"time": "t", "joints": {"hip": {"tau": "tau_hip"}}}, "joint 'hip' has no position q"),
        (
            {
                "time": "t",
                "joints": {},
                "transmission": {"joints": ["hip"], "motors": ["m"], "matrix": [[0.0]]},
                "motors": {"m": {"q": "q_hip"}},
            },
            "matrix is singular",
        ),
        ({"time": "t", "rows": [500, 600], "joints": {"hip": {"q": "q_hip"}}}, "keep no row"),
    ],
)
def test_mapping_spec_errors(tmp_path, spec, message):
    write_recording(tmp_path / "x.csv", leg_data(100))
    with pytest.raises(SpecError) as exc:
        read_recording(tmp_path / "x.csv", mapping=spec)
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_bad_toml(tmp_path):
    p = tmp_path / "m.toml"
    p.write_text("time = \n")
    with pytest.raises(SpecError, match="not valid TOML"):
        MappingSpec.load(p)
    with pytest.raises(SpecError, match="mapping spec not found"):
        MappingSpec.load(tmp_path / "none.toml")


def test_example_specs_parse():
    for p in sorted((Path(__file__).resolve().parents[2] / "docs" / "examples").glob("*.toml")):
        spec = MappingSpec.load(p)
        assert spec.joint_names, p


# ---------------------------------------------------------------------------------------------- checks
def bad_recordings(tmp_path: Path) -> dict[str, tuple[Path, str, dict]]:
    """Each bad-input case: (file, expected message fragment, read_recording keywords)."""
    ds = leg_data(600)
    header = ["t", "q_hip", "q_knee", "tau_hip", "tau_knee"]
    rows = np.column_stack([ds.t, ds.q, ds.tau])
    cases = {}

    def case(name, r, message, header=header, **kw):
        cases[name] = (write_csv(tmp_path / f"{name}.csv", header, r), message, kw)

    r = rows.copy()
    r[300, 0] = r[298, 0]
    case("backwards", r, "time goes backwards at line 302 (t = 1.495 s then 1.49 s)")
    r = rows.copy()
    r[300, 0] = r[299, 0]
    case("duplicate", r, "duplicate time stamp t = 1.495 s at line 301 and line 302")
    r = rows.copy()
    r[10, 3] = np.nan
    case("nan", r, "column 'tau_hip' (joints.hip.tau) has NaN at line 12")
    r = rows.copy()
    r[20, 1] = np.inf
    case("inf", r, "column 'q_hip' (joints.hip.q) has an infinite value at line 22")
    r = rows.copy()
    r[:, 1] = np.degrees(r[:, 1]) * 10
    case(
        "degrees",
        r,
        "positions of joint 'hip' reach 515.7, more than a full turn for a revolute joint: they look like degrees",
    )
    r = rows.copy()
    r[:, 1] = np.degrees(0.05 + 0.03 * np.sin(2 * np.pi * ds.t))
    case(
        "degrees_small",
        r,
        "joint 'hip' reaches 4.584 at line 52, outside its URDF limits [-0.087, 1.309] (URDF exo_leg.urdf); in degrees they would "
        "fit",
    )
    r = rows.copy()
    r[:, 2] = -r[:, 2]
    case(
        "limits",
        r,
        "outside its URDF limits [-1.658, -0.087] (URDF exo_leg.urdf); with the opposite sign they would fit",
    )
    case("missing", rows[:, [0, 1, 3]], "no data for joint 'knee' of exo_leg", header=["t", "q_hip", "tau_hip"])
    case(
        "unknown",
        np.column_stack([rows, rows[:, 1], rows[:, 3]]),
        "joint 'ankle' of the recording is not a joint of exo_leg",
        header=header + ["q_ankle", "tau_ankle"],
    )
    # a cut-off last line: columns of different lengths
    p = write_csv(tmp_path / "cut.csv", header, rows)
    p.write_text(p.read_text() + "3.0,0.5\n")
    cases["cut"] = (p, "line 602 has 2 fields, the first data line 5 (columns of different lengths)", {})
    p = write_csv(tmp_path / "ragged.csv", header, rows)
    lines = p.read_text().splitlines()
    lines[50] = ",".join(lines[50].split(",")[:2])
    p.write_text("\n".join(lines) + "\n")
    cases["ragged"] = (p, "line 51 has 2 fields, the first data line 5 (columns of different lengths)", {})
    p = write_csv(tmp_path / "text.csv", header, rows)
    lines = p.read_text().splitlines()
    lines[7] = lines[7].replace(lines[7].split(",")[2], "abc", 1)
    p.write_text("\n".join(lines) + "\n")
    cases["text"] = (p, "line 8, column 'q_knee': 'abc' is not a number", {})
    np.savez(
        tmp_path / "short.npz",
        t=ds.t,
        q_hip=ds.q[:, 0],
        q_knee=ds.q[:-1, 1],
        tau_hip=ds.tau[:, 0],
        tau_knee=ds.tau[:, 1],
    )
    cases["npz_lengths"] = (tmp_path / "short.npz", "columns of different lengths", {})
    return cases


CASES = [
    "backwards",
    "duplicate",
    "nan",
    "inf",
    "degrees",
    "degrees_small",
    "limits",
    "missing",
    "unknown",
    "cut",
    "ragged",
    "text",
    "npz_lengths",
]


@pytest.mark.parametrize("name", CASES)
def test_checks_api(tmp_path, name):
    path, message, kw = bad_recordings(tmp_path)[name]
    with pytest.raises(DataError) as exc:
        read_recording(path, model=load("exo_leg"), **kw)
    text = str(exc.value)
    assert message in text, text
    assert str(path) in text and "\n" not in text


def test_checks_can_be_softened(tmp_path):
    cases = bad_recordings(tmp_path)
    with pytest.warns(DataWarning, match="outside its URDF limits"):
        ds = read_recording(cases["limits"][0], model=load("exo_leg"), limits="warn")
    assert any("outside its URDF limits" in w for w in ds.meta["warnings"])
    ds = read_recording(cases["degrees_small"][0], model=load("exo_leg"), limits="off")
    assert ds.n == 600
    spec = {
        "time": "t",
        "checks": {"degrees": "off", "limits": "off"},
        "joints": {"hip": {"q": "q_hip", "tau": "tau_hip"}, "knee": {"q": "q_knee", "tau": "tau_knee"}},
    }
    assert read_recording(cases["degrees"][0], mapping=spec, model=load("exo_leg")).n == 600
    with pytest.raises(SpecError, match="check limits = 'maybe'"):
        read_recording(cases["limits"][0], model=load("exo_leg"), limits="maybe")


def test_separate_files_of_different_lengths(tmp_path):
    ds = leg_data(100)
    write_csv(tmp_path / "pos.csv", ["t", "a", "b"], np.column_stack([ds.t, ds.q]))
    write_csv(tmp_path / "tau.csv", ["a", "b"], ds.tau[:-3])
    spec = {
        "time": "t",
        "sources": {"tau": {"path": "tau.csv"}},
        "joints": {
            "hip": {"q": "a", "tau": {"source": "tau", "column": "a"}},
            "knee": {"q": "b", "tau": {"source": "tau", "column": "b"}},
        },
    }
    with pytest.raises(DataError, match=r"tau.csv: 97 rows, but pos.csv has 100 \(columns of different lengths\)"):
        read_recording(tmp_path / "pos.csv", mapping=spec)


# ---------------------------------------------------------------------------------------------- CLI
def _identify(tmp_path, *extra):
    out = tmp_path / "out"
    proc = run_cli("identify", "--urdf", "exo_leg", "--methods", "ols", "--no-report", "-o", str(out), *extra)
    return proc, out


def _nothing_written(out: Path) -> bool:
    return not out.exists() or not any(out.iterdir())


@pytest.mark.parametrize("name", CASES)
def test_cli_bad_recording(tmp_path, name):
    path, message, _ = bad_recordings(tmp_path)[name]
    proc, out = _identify(tmp_path, "--data", str(path))
    assert_clean_error(proc, message, path.name)
    assert _nothing_written(out)


def test_cli_sample_rate_too_low_for_filter(tmp_path):
    ds = leg_data(200, fs=15.0)
    p = write_recording(tmp_path / "slow.csv", Dataset(t=ds.t, q=ds.q, joints=ds.joints, tau=ds.tau))
    proc, out = _identify(tmp_path, "--data", str(p), "--cutoff", "10")
    assert_clean_error(proc, "sample rate 15 Hz is too low for a 10 Hz low-pass", "expected a sample rate above 25 Hz")
    assert _nothing_written(out)


def test_cli_bad_mapping(tmp_path):
    write_recording(tmp_path / "x.csv", leg_data(100))
    spec = tmp_path / "m.toml"
    spec.write_text('time = "t"\n[joints.hip]\nq = { column = "q_hip", sacle = 2 }\n')
    proc, out = _identify(tmp_path, "--data", str(tmp_path / "x.csv"), "--mapping", str(spec))
    assert_clean_error(proc, "unknown key 'sacle' in [joints.hip.q] (did you mean 'scale'?)")
    assert _nothing_written(out)


# ---------------------------------------------------------------------------------------------- doc examples
EXAMPLES = Path(__file__).resolve().parents[2] / "docs" / "examples"


def test_example_rig_degrees_currents(tmp_path):
    ds = leg_data(1500, fs=1000.0)
    raw = np.column_stack([np.degrees(ds.q[:, 0]), -np.degrees(ds.q[:, 1]), ds.tau[:, 0] / 2.865, -ds.tau[:, 1] / 1.91])
    p = tmp_path / "run.txt"
    p.write_text("\n".join(" ".join(f"{v:.12g}" for v in r) for r in raw) + "\n")
    back = read_recording(p, mapping=EXAMPLES / "rig_degrees_currents.toml", model=load("exo_leg"))
    assert back.n == 1000 and back.t[0] == pytest.approx(0.5)
    np.testing.assert_allclose(back.q, ds.q[500:], atol=1e-10)
    np.testing.assert_allclose(back.tau, ds.tau[500:], atol=1e-9)


def test_example_separate_files(tmp_path):
    ds = leg_data(2000, fs=2000.0)
    write_csv(tmp_path / "run7_enc.csv", ["ts_us", "hip_rad", "knee_rad"], np.column_stack([1e6 * ds.t, ds.q]))
    sl = slice(None, None, 4)
    write_csv(tmp_path / "run7_ft.csv", ["stamp", "tau_h", "tau_k"], np.column_stack([ds.t[sl], ds.tau[sl]]))
    with pytest.warns(DataWarning, match="inside every source's time span"):
        back = read_recording(
            tmp_path / "run7_enc.csv", mapping=EXAMPLES / "separate_files.toml", model=load("exo_leg")
        )
    k = np.searchsorted(ds.t, back.t - 1e-12)
    np.testing.assert_allclose(back.tau, ds.tau[k], atol=1e-3 * np.abs(ds.tau).max())


def test_example_wrist_coupling(tmp_path):
    rng = np.random.default_rng(0)
    n = 500
    t = np.arange(n) / 1000.0
    qj = 0.3 * np.sin(np.outer(t, [1.0, 2.0, 3.0]) * 2 * np.pi)
    tj = rng.normal(size=(n, 3))
    R = np.array([[100.0, 0, 0], [0, 50, 50], [0, -50, 50]])
    counts = 2 * np.pi / 4096
    np.savez(tmp_path / "log.npz", t=t, enc=(qj @ R.T) / counts, cur=np.linalg.solve(R.T, tj.T).T / 0.05)
    back = read_recording(tmp_path / "log.npz", mapping=EXAMPLES / "wrist_coupling.toml")
    assert back.joints == ["elbow", "wrist_pitch", "wrist_roll"]
    np.testing.assert_allclose(back.q, qj, atol=1e-8)
    np.testing.assert_allclose(back.tau, tj, atol=1e-8)


def test_a_recording_of_another_robot_names_the_urdf_not_degrees(tmp_path):
    """Issue 33: apal_leg's motion (radians) read against exo_leg (the default --urdf) names the URDF used and
    says the ranges do not fit it, rather than advising a degrees conversion for data already in radians."""
    t = np.arange(200) / 100.0
    q = np.column_stack([-0.5 - 0.5 * np.sin(t), 1.3 + 0.5 * np.sin(t)])  # apal_leg's hip and knee ranges
    path = write_recording(tmp_path / "apal.csv", Dataset(t, q, ["hip", "knee"], tau=np.zeros_like(q)))
    with pytest.raises(DataError) as exc:
        read_recording(path, model=load("exo_leg"))
    assert str(exc.value).endswith(
        "outside its URDF limits [-0.087, 1.309] (URDF exo_leg.urdf); the recording's joint ranges do not fit "
        "exo_leg's: is it the robot recorded (--urdf)?"
    ), str(exc.value)
    assert read_recording(path, model=load("apal_leg")).n == 200
