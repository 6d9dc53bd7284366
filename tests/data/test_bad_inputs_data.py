"""Issue 14, data, mapping specs, URDFs and the plant: each bad input gives one line and exit status 2 from
the CLI (no file left or replaced), or a PinidError subclass from Python.  docs/checks.md lists them."""

from __future__ import annotations

import json
import os
import warnings
from pathlib import Path

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli
from pinid.data.formats import read_recording
from pinid.data.mapping import MappingSpec
from pinid.data.preprocess import prepare
from pinid.errors import DataError, DataWarning, ModelError, SpecError
from pinid.model.robot import RobotModel
from pinid.model.urdf import MAX_URDF_JOINTS

ROOT = Path(__file__).resolve().parents[2]
EXO = (ROOT / "urdf" / "exo_leg.urdf").read_text()
SECRET = "top-secret-line-do-not-print"


def _files(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*") if p.is_file())


@pytest.fixture(scope="module")
def rec(tmp_path_factory) -> Path:
    """A 2 s exo_leg recording in the dataset format, in a folder of its own."""
    folder = tmp_path_factory.mktemp("rec") / "data"
    folder.mkdir()
    t = np.arange(2000) / 1000.0
    q = np.c_[0.6 + 0.4 * np.sin(2 * t), -0.9 + 0.4 * np.sin(3 * t)]
    tau = np.c_[5 + np.sin(2 * t), 1 + np.cos(3 * t)]
    rows = ["t,q_hip,q_knee,tau_hip,tau_knee"] + [
        ",".join(f"{v:.9g}" for v in (a, *b, *c)) for a, b, c in zip(t, q, tau)
    ]
    (folder / "run.csv").write_text("\n".join(rows) + "\n")
    (folder / "run_torque.csv").write_text("\n".join(["k_hip,k_knee"] + [f"{a:.9g},{b:.9g}" for a, b in tau]) + "\n")
    return folder / "run.csv"


def _spec(torque_path: str, column="k_hip") -> dict:
    return {
        "time": "t",
        "joints": {
            "hip": {"q": "q_hip", "tau": {"source": "x", "column": column}},
            "knee": {"q": "q_knee", "tau": {"source": "x", "column": "k_knee"}},
        },
        "sources": {"x": {"path": torque_path}},
    }


def _toml(d: dict) -> str:
    x = d["sources"]["x"]["path"]
    col = d["joints"]["hip"]["tau"]["column"]
    col = f'"{col}"' if isinstance(col, str) else col
    return (
        f'time = "t"\n[joints.hip]\nq = "q_hip"\ntau = {{ source = "x", column = {col} }}\n'
        f'[joints.knee]\nq = "q_knee"\ntau = {{ source = "x", column = "k_knee" }}\n'
        f'[sources.x]\npath = "{x}"\n'
    )


def _identify(tmp_path: Path, *args: str):
    out = tmp_path / "results"
    return run_cli("identify", "--urdf", "exo_leg", "--methods", "ols", "--no-report", "-o", str(out), *args), out


# ------------------------------------------------------------------ 1. mapping paths stay in the recording's folder
@pytest.mark.parametrize("where", ["absolute", "climbing", "symlink"])
def test_source_path_outside_the_folder_is_refused(tmp_path, rec, where):
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "secret.csv").write_text(f"{SECRET},x\n1,2\n")
    path = {"absolute": str(outside / "secret.csv"), "climbing": "../../outside/secret.csv", "symlink": "link.csv"}[
        where
    ]
    if where == "symlink":
        link = rec.parent / "link.csv"
        if not link.exists():
            os.symlink(outside / "secret.csv", link)
    if where == "climbing":  # the recording two levels below tmp_path
        data = tmp_path / "a" / "b"
        data.mkdir(parents=True)
        (data / "run.csv").write_text(rec.read_text())
        recording = data / "run.csv"
    else:
        recording = rec
    with pytest.raises(SpecError, match="leads outside"):
        read_recording(recording, mapping=_spec(path))
    spec = tmp_path / "m.toml"
    spec.write_text(_toml(_spec(path)))
    proc, out = _identify(tmp_path, "--data", str(recording), "--mapping", str(spec))
    assert_clean_error(proc, "leads outside", "--allow-outside-paths")
    assert SECRET not in proc.stderr and not out.exists()
    # allowed explicitly: read, and the file (not a recording of these columns) is not echoed
    with pytest.raises(SpecError) as info:
        read_recording(recording, mapping=_spec(path), allow_outside_paths=True)
    assert SECRET not in str(info.value) and "not shown" in str(info.value)
    proc, out = _identify(tmp_path, "--data", str(recording), "--mapping", str(spec), "--allow-outside-paths")
    assert_clean_error(proc, "not shown")
    assert SECRET not in proc.stderr and not out.exists()


def test_source_path_inside_the_folder_still_works(rec):
    ds = read_recording(rec, mapping=_spec("{stem}_torque.csv"))
    assert ds.tau.shape == (2000, 2)
    assert ds.tau[0, 0] == pytest.approx(5.0)


def test_compare_takes_the_flag_too():
    assert "--allow-outside-paths" in run_cli("compare", "--help").stdout


@pytest.mark.parametrize("header", [True, False])
def test_a_file_that_is_not_a_recording_is_not_echoed(tmp_path, rec, header):
    (rec.parent / "notes.csv").write_text(f"{SECRET} one,{SECRET} two\n{SECRET},x\n")
    spec = _spec("notes.csv", column=0 if not header else "k_hip")
    spec["sources"]["x"]["header"] = header
    if not header:
        spec["joints"]["knee"]["tau"]["column"] = 1
    with pytest.raises((SpecError, DataError)) as info:
        read_recording(rec, mapping=spec)
    assert SECRET not in str(info.value)


def test_an_npz_that_is_not_a_recording_is_not_echoed(rec):
    np.savez(rec.parent / "other.npz", **{SECRET: np.zeros(3)})
    for column in ("k_hip", 0):
        spec = _spec("other.npz", column=column)
        with pytest.raises(SpecError) as info:
            read_recording(rec, mapping=spec)
        assert SECRET not in str(info.value)


# ------------------------------------------------------------------ 2. only the documented placeholders, literally
@pytest.mark.parametrize(
    "path, fragment",
    [
        ("{foo}.csv", "unknown placeholder {foo}"),
        ("{0}.csv", "unknown placeholder {0}"),
        ("{stem.__class__.__doc__}", "unknown placeholder {stem.__class__.__doc__}"),
        ("{stem!r}.csv", "unknown placeholder"),
        ("run{.csv", "unmatched brace"),
        ("run}.csv", "unmatched brace"),
    ],
)
def test_source_path_placeholders(tmp_path, rec, path, fragment):
    with pytest.raises(SpecError, match="expected {stem}, {name}, {suffix}") as info:
        MappingSpec.load(_spec(path))
    assert fragment in str(info.value)
    assert "Return a nice string" not in str(info.value) and "str(object=" not in str(info.value)
    spec = tmp_path / "m.toml"
    spec.write_text(_toml(_spec(path)))
    proc, out = _identify(tmp_path, "--data", str(rec), "--mapping", str(spec))
    assert_clean_error(proc, fragment)
    assert not out.exists()


def test_placeholders_are_substituted_literally(tmp_path):
    folder = tmp_path / "d"
    folder.mkdir()
    name = "x{stem}y"  # a main file whose name has braces: substituted as text, never parsed again
    t = np.arange(100) / 100.0
    (folder / f"{name}.csv").write_text("t,q_hip,q_knee\n" + "".join(f"{a},0.1,-0.2\n" for a in t))
    (folder / f"{name}_tau.csv").write_text("k_hip,k_knee\n" + "".join("1,2\n" for _ in t))
    ds = read_recording(folder / f"{name}.csv", mapping=_spec("{stem}_tau.csv"))
    assert ds.tau[0].tolist() == [1.0, 2.0]


# ------------------------------------------------------------------ 22. negative column indices: one rule
@pytest.mark.parametrize("q", [-4, {"column": -4}])
def test_negative_column_index_is_refused_in_both_forms(tmp_path, rec, q):
    spec = {"time": "t", "joints": {"hip": {"q": q}, "knee": {"q": "q_knee"}}}
    with pytest.raises(SpecError, match="0-based index >= 0"):
        MappingSpec.load(spec)
    toml = tmp_path / "m.toml"
    toml.write_text(
        'time = "t"\n[joints.hip]\nq = '
        + ("-4" if q == -4 else "{ column = -4 }")
        + '\ntau = "tau_hip"\n[joints.knee]\nq = "q_knee"\ntau = "tau_knee"\n'
    )
    proc, out = _identify(tmp_path, "--data", str(rec), "--mapping", str(toml))
    assert_clean_error(proc, "-4", "0-based index >= 0")
    assert not out.exists()


# ------------------------------------------------------------------ 7. deeply nested TOML
@pytest.mark.parametrize("kind", ["arrays", "inline tables", "dotted tables"])
def test_deeply_nested_toml_is_one_line(tmp_path, rec, kind):
    n = 5000
    body = {
        "arrays": "x = " + "[" * n + "]" * n,
        "inline tables": "x = " + "{a = " * n + "1" + "}" * n,
        "dotted tables": "[" + ".".join(["a"] * n) + "]\nb = 1",
    }[kind]
    spec = tmp_path / "deep.toml"
    spec.write_text(body + "\n")
    with pytest.raises(SpecError, match="nested deeper than 64 levels|not valid TOML"):
        MappingSpec.load(spec)
    proc, out = _identify(tmp_path, "--data", str(rec), "--mapping", str(spec))
    assert_clean_error(proc, str(spec))
    assert not out.exists()
    for args in (
        ["info", "--urdf", "exo_leg", "--drives", str(spec)],
        ["excite", "--urdf", "exo_leg", "--spec", str(spec), "-o", str(tmp_path / "e.json")],
        ["flex", "check", "--spec", str(spec)],
    ):
        proc = run_cli(*args)
        assert proc.returncode == 2 and "RecursionError" not in proc.stderr, (args, proc.stderr)
        assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert _files(tmp_path) == ["deep.toml"]


def test_deeply_nested_json_spec(tmp_path):
    spec = tmp_path / "deep.json"
    spec.write_text("[" * 100000 + "]" * 100000)
    proc = run_cli("excite", "--urdf", "exo_leg", "--spec", str(spec), "-o", str(tmp_path / "e.json"))
    assert_clean_error(proc, "nested deeper")
    assert _files(tmp_path) == ["deep.json"]


# ------------------------------------------------------------------ URDFs: 3, 4, 10
def _chain(n: int) -> str:
    links = "".join(f'<link name="l{i}"/>' for i in range(n + 1))
    joints = "".join(
        f'<joint name="j{i}" type="fixed"><parent link="l{i}"/><child link="l{i + 1}"/></joint>' for i in range(n)
    )
    movable = (
        '<link name="tip"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" '
        f'izz="0.1"/></inertial></link><joint name="q" type="revolute"><parent link="l{n}"/><child link="tip"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>'
    )
    return f'<robot name="chain">{links}{joints}{movable}</robot>'


def _exo_with(old: str, new: str) -> str:
    assert old in EXO, old
    return EXO.replace(old, new, 1)


_KNEE_JOINT = '<joint name="knee" type="revolute">'
URDF_CASES = {
    # 3: urdfdom recurses once per joint and crashes (segfault) on thousands of them
    "6000 fixed joints": (_chain(6000), f"more than pinid accepts ({MAX_URDF_JOINTS})"),
    # 4
    "lower above upper": (
        _exo_with('lower="-0.087" upper="1.309"', 'lower="1.309" upper="-0.087"'),
        "joint 'hip' has lower limit 1.309 above its upper limit -0.087",
    ),
    "two parent joints": (
        _exo_with(
            "</robot>",
            '<joint name="loop" type="revolute"><parent link="trunk"/>'
            '<child link="shank"/><axis xyz="0 1 0"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>',
        ),
        "link 'shank' is the child of joints 'knee' and 'loop'",
    ),
    "zero axis": (_exo_with('<axis xyz="0 -1 0"/>', '<axis xyz="0 0 0"/>'), "joint 'hip' has axis xyz=\"0 0 0\""),
}


def _bad_inertia(text: str, ixx: str, iyy: str, izz: str) -> str:
    import re

    return re.sub(
        r"<inertia [^>]*/>", f'<inertia ixx="{ixx}" ixy="0" ixz="0" iyy="{iyy}" iyz="0" izz="{izz}"/>', text, count=2
    )


URDF_CASES["negative moment"] = (_bad_inertia(EXO, "-0.1", "0.1", "0.1"), "a negative principal moment")
URDF_CASES["triangle inequality"] = (
    _bad_inertia(EXO, "0.01", "0.01", "0.5"),
    "one moment larger than the sum of the other two",
)


@pytest.mark.parametrize("case", sorted(URDF_CASES))
def test_bad_urdf_is_refused(tmp_path, case):
    text, fragment = URDF_CASES[case]
    p = tmp_path / "robot.urdf"
    p.write_text(text)
    with pytest.raises(ModelError, match=None) as info:
        RobotModel.from_urdf(p)
    assert fragment in str(info.value)
    assert_clean_error(run_cli("info", "--urdf", str(p), "--json", str(tmp_path / "i.json")), fragment)
    assert_clean_error(
        run_cli(
            "simulate", "--urdf", str(p), "--excitation", "zha2019-1", "--seconds", "1", "-o", str(tmp_path / "s.csv")
        ),
        fragment,
    )
    assert _files(tmp_path) == ["robot.urdf"]


def test_urdf_joint_limit_boundary_and_deep_elements(tmp_path):
    p = tmp_path / "chain.urdf"
    p.write_text(_chain(MAX_URDF_JOINTS - 1))  # 1000 joints in all: loads (in about 0.04 s)
    assert RobotModel.from_urdf(p).joint_names == ["q"]
    deep = tmp_path / "deep.urdf"  # deeply nested elements (not joints): the XML parser's own limit
    deep.write_text(EXO.replace("</robot>", "<a>" * 200000 + "</a>" * 200000 + "</robot>"))
    assert_clean_error(run_cli("info", "--urdf", str(deep)), "nesting is too deep")


def test_inertia_tolerance_accepts_rounding_and_thin_rods(tmp_path):
    p = tmp_path / "robot.urdf"
    # a thin rod (Izz = 0, Ixx = Iyy: the triangle inequality holds with equality) and a CAD rounding below 1e-6
    p.write_text(_bad_inertia(EXO, "0.02", "0.0200000001", "0"))
    assert RobotModel.from_urdf(p).nv == 2


@pytest.mark.parametrize("name", ["exo_leg", "apal_leg", "tracker_2dof", "ur5", "panda", "double_pendulum"])
def test_shipped_and_example_robots_still_load(name):
    assert RobotModel.from_urdf(name).nv >= 2  # panda: its mimic finger joint is locked


# 10: a mimic joint is locked (issue 28: without --joints), refused when named active
MIMIC_KNEE = _exo_with(_KNEE_JOINT, _KNEE_JOINT + '<mimic joint="hip" multiplier="1"/>')


def test_locked_mimic_joint_is_fine(tmp_path):
    p = tmp_path / "robot.urdf"
    p.write_text(MIMIC_KNEE)
    assert RobotModel.from_urdf(p, locked={"knee": -0.5}).joint_names == ["hip"]
    assert RobotModel.from_urdf(p).joint_names == ["hip"]  # locked at its neutral value
    with pytest.raises(ModelError, match="mimic joints are not supported: joint 'knee' mimics 'hip'"):
        RobotModel.from_urdf(p, joints=["hip", "knee"])


def test_ok_urdf_through_identify_refused_when_inertia_bad(tmp_path, rec):
    p = tmp_path / "robot.urdf"
    p.write_text(URDF_CASES["triangle inequality"][0])
    proc = run_cli("identify", "--urdf", str(p), "--data", str(rec), "--methods", "ols", "-o", str(tmp_path / "r"))
    assert_clean_error(proc, "one moment larger than the sum")
    assert _files(tmp_path) == ["robot.urdf"]


# ------------------------------------------------------------------ 12. simulate maps trajectory joints by name
def _trajectory(path: Path, joints: list[str]) -> Path:
    path.write_text(
        json.dumps(
            {
                "joints": joints,
                "base_frequency": 0.5,
                "harmonics": 1,
                "q0": [-0.9, 0.6],
                "a": [[0.3], [0.0]],
                "b": [[0.0], [0.0]],
            }
        )
    )
    return path


def test_simulate_maps_trajectory_joints_by_name(tmp_path):
    tr = _trajectory(tmp_path / "tr.json", ["knee", "hip"])
    out = tmp_path / "out.csv"
    proc = run_cli("simulate", "--urdf", "exo_leg", "--excitation", str(tr), "--seconds", "1", "-o", str(out))
    assert proc.returncode == 0, proc.stderr
    d = np.genfromtxt(out, delimiter=",", names=True)
    assert d["q_hip"][0] == pytest.approx(0.6, abs=1e-3)  # hip's q0, not knee's
    assert d["q_knee"][0] == pytest.approx(-0.9, abs=1e-3)
    assert np.ptp(d["q_hip"]) < 0.01 < np.ptp(d["q_knee"])  # the knee carries the 0.3 rad harmonic


def test_excite_evaluate_maps_trajectory_joints_by_name(tmp_path):
    ordered = _trajectory(tmp_path / "hk.json", ["hip", "knee"])
    d = json.loads(ordered.read_text())
    swapped = tmp_path / "kh.json"
    swapped.write_text(
        json.dumps({**d, "joints": ["knee", "hip"], "q0": d["q0"][::-1], "a": d["a"][::-1], "b": d["b"][::-1]})
    )
    said = [run_cli("excite", "--urdf", "exo_leg", "--evaluate", str(p)) for p in (ordered, swapped)]
    assert [p.returncode for p in said] == [0, 0], said[1].stderr
    cond = [
        next(ln.split("condition number ")[1].split()[0] for ln in p.stdout.splitlines() if "condition number" in ln)
        for p in said
    ]
    assert cond[0] == cond[1]


def test_simulate_unknown_trajectory_joint(tmp_path):
    tr = _trajectory(tmp_path / "tr.json", ["knee", "foo"])
    proc = run_cli(
        "simulate", "--urdf", "exo_leg", "--excitation", str(tr), "--seconds", "1", "-o", str(tmp_path / "o.csv")
    )
    assert_clean_error(proc, "['knee', 'foo']", "['hip', 'knee']")
    assert _files(tmp_path) == ["tr.json"]


# ------------------------------------------------------------------ 16. track --model of another robot
def test_track_model_with_other_joint_types(tmp_path):
    p = tmp_path / "prismatic_knee.urdf"
    p.write_text(_exo_with(_KNEE_JOINT, '<joint name="knee" type="prismatic">'))
    proc = run_cli("track", "--model", str(p), "--seconds", "1", "--after", "0.5", "-o", str(tmp_path / "t"))
    assert_clean_error(proc, "joint 'knee' is prismatic in the model but revolute in the plant")
    assert _files(tmp_path) == ["prismatic_knee.urdf"]


def test_track_model_with_other_joint_names(tmp_path):
    p = tmp_path / "renamed.urdf"
    p.write_text(EXO.replace('"knee"', '"shin"'))
    proc = run_cli("track", "--model", str(p), "--seconds", "1", "--after", "0.5", "-o", str(tmp_path / "t"))
    assert_clean_error(proc, "knee")
    assert _files(tmp_path) == ["renamed.urdf"]


# ------------------------------------------------------------------ 15. continuous joints: wrapped data unwrapped
def test_wrapped_continuous_joint_is_unwrapped(tmp_path):
    from pinid.data.dataset import Dataset
    from pinid.problem.recordings import free_angles, load_datasets

    p = tmp_path / "continuous_hip.urdf"
    p.write_text(_exo_with('<joint name="hip" type="revolute">', '<joint name="hip" type="continuous">'))
    model = RobotModel.from_urdf(p)
    free = free_angles(model)
    assert free == ["hip"]
    j = 0
    t = np.arange(4000) / 1000.0
    q = np.zeros((t.size, model.nv))
    q[:, j] = 1.5 * t  # 6 rad: wraps once
    q[:, 1] = -0.9 + 0.2 * np.sin(t)
    tau = np.ones_like(q)
    wrapped = q.copy()
    wrapped[:, j] = (q[:, j] + np.pi) % (2 * np.pi) - np.pi
    ds = Dataset(t=t, q=wrapped, joints=model.joint_names, tau=tau, source="wrapped")
    out = load_datasets(ds, model)[0]
    assert out.meta["preprocess"]["unwrapped"] == [free[0]]
    assert np.allclose(out.dq[:, j], 1.5, atol=1e-3)  # without unwrapping: a spike of ~2π·1000 rad/s
    with pytest.warns(DataWarning):  # the plain preprocessing step unwraps only when told
        plain = prepare(ds)
    assert np.abs(plain.dq[:, j]).max() > 100


# ------------------------------------------------------------------ 19. duplicate column
def test_duplicate_column_is_named(tmp_path, rec):
    lines = rec.read_text().splitlines()
    lines = [ln + "," + ln.split(",")[1] for ln in lines]  # a second q_hip
    bad = tmp_path / "dup.csv"
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(DataError, match="column 'q_hip' appears 2 times"):
        read_recording(bad)
    proc, out = _identify(tmp_path, "--data", str(bad))
    assert_clean_error(proc, "column 'q_hip' appears 2 times in the header")
    assert not out.exists()


# ------------------------------------------------------------------ 23. no low-pass warning on a joint held still
def test_no_lowpass_warning_on_a_still_joint():
    from pinid.data.dataset import Dataset

    rng = np.random.default_rng(0)
    t = np.arange(5000) / 1000.0
    q = np.c_[1e-4 * rng.standard_normal(t.size), 0.5 * np.sin(2 * t)]  # hip held: encoder noise only
    ds = Dataset(t=t, q=q, joints=["hip", "knee"], tau=np.ones_like(q), source="still")
    with warnings.catch_warnings():
        warnings.simplefilter("error", DataWarning)
        prepare(ds)
    moving = Dataset(
        t=t,
        q=np.c_[0.05 * np.sin(2 * np.pi * 40 * t), q[:, 1]],
        joints=["hip", "knee"],
        tau=np.ones_like(q),
        source="fast",
    )
    with pytest.warns(DataWarning, match="removes .* of joint 'hip'"):
        prepare(moving)
