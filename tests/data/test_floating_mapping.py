"""Floating recordings with their own column names and units, read through a mapping spec's [floating]
table (issue 27): the same identification as from the dataset-format file."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from conftest import assert_clean_error, run_cli

from pinid import RobotModel
from pinid.identification.study import Study
from pinid.data.formats import read_recording, write_recording
from pinid.errors import DataError, SpecError
from pinid.identification.run import identify
from pinid.simulation.floating_twin import simulate_gait, simulate_suspended
from conftest import floating_excitation as excitation

EXO = ["--urdf", "exo_lower_body", "--base", "floating"]
#: dataset-format column → (foreign name, factor raw = factor · SI)
FOREIGN = {
    "t": ("time_ms", 1e3),
    "q_l_knee": ("KneeL_deg", 180 / np.pi),
    "base_x": ("pelvis_X_mm", 1e3),
    "base_y": ("pelvis_Y_mm", 1e3),
    "base_z": ("pelvis_Z_mm", 1e3),
    "imu_imu_wx": ("gyro_x", 180 / np.pi),
    "imu_imu_wy": ("gyro_y", 180 / np.pi),
    "imu_imu_wz": ("gyro_z", 180 / np.pi),
    "imu_imu_az": ("acc_z_g", 1 / 9.80665),
    "wrench_pelvis_fz": ("loadcell_Fz_kN", 1e-3),
    "plate_l_sole_fz": ("FP1_Fz", 1.0),
    "contact_r_sole": ("FS_right", 1.0),
}
UNITS = {"time_ms": "ms", "KneeL_deg": "deg", "acc_z_g": "g", "loadcell_Fz_kN": "kN"}
UNITS |= {f"pelvis_{c}_mm": "mm" for c in "XYZ"} | {f"gyro_{c}": "deg/s" for c in "xyz"}


def foreign(src, dst, spec):
    """Rewrite the dataset-format CSV ``src`` with foreign names and units to ``dst``; its mapping spec to ``spec``."""
    with open(src) as f:
        rows = list(csv.reader(f))
    head, data = rows[0], np.array(rows[1:], dtype=float)
    names = []
    for j, h in enumerate(head):
        name, factor = FOREIGN.get(h, (f"col_{h}", 1.0))
        data[:, j] *= factor
        names.append(name)
    with open(dst, "w", newline="") as f:
        w = csv.writer(f, delimiter=";")
        w.writerow(names)
        w.writerows([[repr(float(x)) for x in r] for r in data])

    def ref(h):
        name = FOREIGN.get(h, (f"col_{h}",))[0]
        return f'{{ column = "{name}", scale = "{UNITS[name]}" }}' if name in UNITS else f'"{name}"'

    joint = ("q_", "dq_", "ddq_", "tau_")
    lines = ['delimiter = ";"', f"time = {ref('t')}", "[floating]"]
    lines += [f"{h} = {ref(h)}" for h in head if h != "t" and not h.startswith(joint)]
    for j in [h[2:] for h in head if h.startswith("q_")]:
        lines.append(f"[joints.{j}]")
        lines += [f"{k[:-1]} = {ref(k + j)}" for k in joint if k + j in head]
    spec.write_text("\n".join(lines) + "\n")


@pytest.fixture(scope="module")
def exo():
    return RobotModel.from_urdf("exo_lower_body", base="floating")


@pytest.mark.parametrize("kind", ["suspended", "gait"])
def test_foreign_names_and_units_identify_as_the_dataset_format(exo, kind, tmp_path):
    """A recording with its own column names, ';' and units (ms, deg for a joint, mm, deg/s, g, kN) read
    through a mapping spec gives the same signals and the same identification as the dataset-format file."""
    if kind == "suspended":
        twin = simulate_suspended(exo, excitation(exo), seconds=3, rate=100, imu_frame="imu")
    else:
        twin = simulate_gait(exo, seconds=3, rate=100)
    write_recording(tmp_path / "mine.csv", twin.recording)
    foreign(tmp_path / "mine.csv", tmp_path / "theirs.csv", tmp_path / "map.toml")
    a = read_recording(tmp_path / "mine.csv", model=exo)
    b = read_recording(tmp_path / "theirs.csv", model=exo, mapping=tmp_path / "map.toml")
    np.testing.assert_allclose(b.t, a.t, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(b.q, a.q, rtol=1e-10, atol=1e-12)
    ca, cb = a.floating.columns(), b.floating.columns()
    assert sorted(ca) == sorted(cb)
    for name in ca:
        np.testing.assert_allclose(cb[name], ca[name], rtol=1e-10, atol=1e-9, err_msg=name)
    r = {
        src: identify(Study(exo, tmp_path / src, mapping=m), methods=("ols",)).results["ols"].base
        for src, m in (("mine.csv", None), ("theirs.csv", tmp_path / "map.toml"))
    }
    np.testing.assert_allclose(r["theirs.csv"], r["mine.csv"], rtol=1e-6, atol=1e-8)
    assert r["theirs.csv"][0] == pytest.approx(21.8, rel=0.01)  # the total mass
    proc = run_cli("identify", *EXO, "--data", "theirs.csv", "--mapping", "map.toml", "--methods", "ols",
                   "--no-report", "-o", "res", cwd=tmp_path)  # fmt: skip
    assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize(
    "table, words",
    [
        ('base_w = "x"', "[floating] base_w: not a floating column"),
        ('wrench_pelvis_fz = { column = "x", scale = "parsec" }', "scale"),
        ("wrench_pelvis_fz = 3.5", "[floating.wrench_pelvis_fz]"),
    ],
)
def test_bad_floating_mapping_is_one_line_and_writes_nothing(exo, table, words, tmp_path):
    spec = tmp_path / "map.toml"
    spec.write_text('time = "t"\n[joints.l_knee]\nq = "k"\n[floating]\n' + table + "\n")
    (tmp_path / "d.csv").write_text("t,k\n0,0\n0.01,0\n")
    with pytest.raises(SpecError, match=words.replace("[", r"\[").replace("]", r"\]")):
        read_recording(tmp_path / "d.csv", model=exo, mapping=spec)
    proc = run_cli(
        "identify", *EXO, "--data", "d.csv", "--mapping", "map.toml", "--no-report", "-o", "out", cwd=tmp_path
    )
    assert_clean_error(proc, words)
    assert not (tmp_path / "out").exists()


def test_joint_and_floating_sources_keep_one_common_time_span(exo, tmp_path):
    """Round 4 finding 11: torques from a logger that started 0.5 s late and a wrench from one that stopped
    0.5 s early were each trimmed to their own span (the same number of samples, different ones: the wrench
    paired with motion 0.5 s away, train RMS × 20).  Now both keep the samples inside every source: the same
    signals as the one-file recording cut to the common span."""
    twin = simulate_suspended(exo, excitation(exo), seconds=3, rate=100, imu_frame="imu")
    full = read_recording(write_recording(tmp_path / "s.csv", twin.recording), model=exo)
    with open(tmp_path / "s.csv") as f:
        rows = list(csv.reader(f))
    head, a = rows[0], np.array(rows[1:], dtype=float)
    t = a[:, 0]
    joints = [h[2:] for h in head if h.startswith("q_")]
    base = [h for h in head if h.startswith(("base_", "imu_"))]
    wc = [h for h in head if h.startswith("wrench_")]

    def write(name, cols, mask):
        np.savetxt(tmp_path / name, a[np.ix_(mask, [head.index(c) for c in cols])], delimiter=",",
                   header=",".join(cols), comments="", fmt="%.17g")  # fmt: skip

    every = np.ones(len(t), bool)
    late, early = t >= 0.5, t <= t[-1] - 0.5
    write("main.csv", ["t"] + [f"q_{j}" for j in joints] + base, every)
    write("tq.csv", ["t"] + [f"tau_{j}" for j in joints], late)
    write("ft.csv", ["t"] + wc, early)
    spec = ['time = "t"', "[sources.tq]", 'path = "tq.csv"', 'time = "t"', "[sources.ft]", 'path = "ft.csv"']
    spec += ['time = "t"']
    for j in joints:
        spec += [f"[joints.{j}]", f'q = "q_{j}"', f'tau = {{ source = "tq", column = "tau_{j}" }}']
    spec += ["[floating]"] + [f'{c} = "{c}"' for c in base] + [f'{c} = {{ source = "ft", column = "{c}" }}' for c in wc]
    (tmp_path / "map.toml").write_text("\n".join(spec) + "\n")
    with pytest.warns(UserWarning, match=f"kept {int((late & early).sum())} of {len(t)} samples"):
        rec = read_recording(tmp_path / "main.csv", model=exo, mapping=tmp_path / "map.toml")
    inside = late & early
    np.testing.assert_allclose(rec.t, t[inside], atol=1e-12)
    np.testing.assert_allclose(rec.tau, full.tau[inside], atol=1e-9)
    np.testing.assert_allclose(rec.floating.wrenches["pelvis"], full.floating.wrenches["pelvis"][inside], atol=1e-9)
    np.testing.assert_allclose(rec.q, full.q[inside], atol=1e-9)
    # no common span: one line
    write("ft.csv", ["t"] + wc, t <= 0.4)
    with pytest.raises(DataError, match=r"no common time span"):
        read_recording(tmp_path / "main.csv", model=exo, mapping=tmp_path / "map.toml")


def test_one_mapping_class_for_fixed_and_floating_bases(exo, tmp_path):
    """Issue 32: a mapping spec is one MappingSpec whatever the base; its [floating] table is an optional field
    (floating column → ColumnRef, units converted to SI), read with the joints by read_all; a [floating] table
    for a fixed-base robot (or no model) is one line."""
    import pinid.data.contacts as contacts
    from pinid.data.mapping import MappingSpec

    assert not hasattr(contacts, "FloatingMapping") and not hasattr(contacts, "floating_mapping")
    spec = MappingSpec.load(
        {
            "time": "t",
            "joints": {"l_knee": {"q": "k"}},
            "floating": {"wrench_pelvis_fz": {"column": "f", "scale": "kN"}, "contact_r_sole": "c"},
        }
    )
    assert (
        list(spec.floating) == ["wrench_pelvis_fz", "contact_r_sole"] and spec.floating["wrench_pelvis_fz"].scale == 1e3
    )
    assert MappingSpec.load({"time": "t", "joints": {"l_knee": {"q": "k"}}}).floating == {}
    (tmp_path / "d.csv").write_text("t,k,f,c\n0,0.1,0.5,1\n0.01,0.2,0.25,0\n")
    ds, columns = spec.read_all(tmp_path / "d.csv")
    np.testing.assert_array_equal(ds.q[:, 0], [0.1, 0.2])
    np.testing.assert_array_equal(columns["wrench_pelvis_fz"], [500.0, 250.0])  # kN → N
    np.testing.assert_array_equal(columns["contact_r_sole"], [1.0, 0.0])
    assert spec.read(tmp_path / "d.csv").n == 2
    for model in (RobotModel.from_urdf("exo_leg"), None):
        with pytest.raises(SpecError) as err:
            read_recording(tmp_path / "d.csv", model=model, mapping=spec)
        assert "a [floating] table (wrench_pelvis_fz, contact_r_sole)" in str(err.value)
        assert "expected a floating model" in str(err.value) and "\n" not in str(err.value)
    (tmp_path / "map.toml").write_text('time = "t"\n[joints.knee]\nq = "k"\n[floating]\ncontact_r_sole = "c"\n')
    proc = run_cli(
        "identify", "--urdf", "exo_leg", "--data", "d.csv", "--mapping", "map.toml", "-o", "out", cwd=tmp_path
    )
    assert_clean_error(proc, "expected a floating model")
    assert not (tmp_path / "out").exists()
