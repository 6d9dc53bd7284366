"""Recordings as they come (issue 28): dataset manifests, --fit-joints, torque delays, imperfect vendor URDFs
(inertias repaired on request, mimic joints), and motor Coulomb friction at rest behind a coupled transmission.

Ground truth: twins with known parameters (tests/identification/test_identification.py, tests/model/test_drives.py), a file split
by hand, rows dropped by hand, a known delay, inertias whose nearest physical one is checked against the
constraint set.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np
import pytest

from pinid import base_parameters, regressor, standard_parameters
from pinid.identification.study import Study
from pinid.cli.common import recording_options
from pinid.data.dataset import Dataset
from pinid.data.delay import parse_delay, shift_torque
from pinid.data.formats import write_recording
from pinid.data.manifest import Manifest
from pinid.errors import DataError, ModelError, ModelWarning, SpecError
from pinid.identification.delay import estimate_delay
from pinid.problem.problem import IdentificationProblem
from pinid.problem.rows import motor_kept_rows, rest_thresholds
from pinid.identification.outputs import identification_text
from pinid.identification.run import identify
from pinid.model.robot import RobotModel, nearest_physical_inertia

from conftest import assert_clean_error, run_cli
from test_drives import MOTOR_TERMS, coupled
from test_drives import twin as drive_twin
from test_identification import truth_model, twin


# ---------------------------------------------------------------------------------------------- manifest
@pytest.fixture(scope="module")
def one_file(tmp_path_factory):
    """One exo_leg recording (t, q, tau: preprocessing fills dq, ddq) and the same rows split by hand."""
    folder = tmp_path_factory.mktemp("manifest")
    m = truth_model("exo_leg")
    ds = twin(m, seconds=24, rate=200, seed=3, noise=0.05)
    write_recording(folder / "run.csv", Dataset(ds.t, ds.q, ds.joints, tau=ds.tau, source="run"))
    lines = (folder / "run.csv").read_text().splitlines(keepends=True)
    split = 1 + 3200  # header + 16 s of training rows
    (folder / "train.csv").write_text("".join(lines[:split]))
    (folder / "valid.csv").write_text("".join(lines[:1] + lines[split:]))
    return m, folder


def _write(folder, text, name="study.toml"):
    (folder / name).write_text(text)
    return folder / name


@pytest.mark.parametrize(
    "ranges",
    [("rows = [0, 3200]", "rows = [3200]"), ("time = [0.0, 15.999]", "time = [15.999, 100.0]")],
)
def test_manifest_ranges_of_one_file_equal_the_file_split_by_hand(one_file, ranges):
    m, folder = one_file
    study = _write(
        folder,
        f'[[recording]]\nfile = "run.csv"\nrole = "train"\n{ranges[0]}\n'
        f'[[recording]]\nfile = "run.csv"\nrole = "validate"\n{ranges[1]}\n',
    )
    by_hand = identify(Study(m, folder / "train.csv", validate=folder / "valid.csv"), methods="ols,sdp")
    listed = identify(Study.from_manifest(study, m), methods="ols,sdp")
    for method in ("ols", "sdp"):
        assert np.array_equal(listed[method].base, by_hand[method].base), method
        assert listed[method].validation.all == by_hand[method].validation.all
    assert listed.data["rows"] == by_hand.data["rows"] and listed.data["manifest"] == str(study)


@pytest.mark.parametrize(
    "text, error, fragment",
    [
        ('[[recording]]\nfile = "run.csv"\nrole = "train"\nrange = [0, 1]\n', SpecError, "unknown key(s) range"),
        ('colour = 1\n[[recording]]\nfile = "run.csv"\nrole = "train"\n', SpecError, "unknown key(s) colour"),
        ('[[recording]]\nfile = "nothere.csv"\nrole = "train"\n', SpecError, "nothere.csv not found"),
        ('[[recording]]\nfile = "run.csv"\nrole = "test"\n', SpecError, "expected one of train, validate, payload"),
        ('[[recording]]\nfile = "run.csv"\nrole = "validate"\n', SpecError, 'no recording with role = "train"'),
        (
            '[[recording]]\nfile = "run.csv"\nrole = "train"\nrows = [0, 2000]\n'
            '[[recording]]\nfile = "run.csv"\nrole = "validate"\nrows = [1500, 3000]\n',
            DataError,
            "share rows 1500–1999 of run.csv",
        ),
        ('[[recording]]\nfile = "run.csv"\nrole = "train"\ntime = [50, 60]\n', DataError, "no sample with 50"),
        ('[[recording]]\nfile = "run.csv"\nrole = "train"\nrows = [9000]\n', DataError, "select no row"),
        ('[[recording]]\nfile = "run.csv"\nrole = "train"\nrows = [5, 5]\n', SpecError, "0 ≤ first < stop"),
        (  # issue 33 (06): a copy of the file (train.csv holds run.csv's first 3200 rows) shares samples
            '[[recording]]\nfile = "train.csv"\nrole = "train"\n'
            '[[recording]]\nfile = "run.csv"\nrole = "validate"\nrows = [3000, 4000]\n',
            DataError,
            "run.csv[rows 3000:4000] (validate) and train.csv (train) share 200 samples (the same t, q and tau",
        ),
        (  # issue 33 (06): a stop past the end is refused, not clipped
            '[[recording]]\nfile = "run.csv"\nrole = "train"\nrows = [3000, 400000]\n',
            DataError,
            "rows 3000:400000 go past the end of run.csv, which has 4800 rows; expected a stop ≤ 4800",
        ),
    ],
)
def test_bad_manifests_are_one_line_errors(one_file, text, error, fragment):
    m, folder = one_file
    path = _write(folder, text, "bad.toml")
    with pytest.raises(error) as info:
        Manifest.load(path).read(m)
    assert fragment in str(info.value) and "\n" not in str(info.value)


def test_manifest_overlap_allowed_on_request_with_a_warning(one_file):
    m, folder = one_file
    path = _write(
        folder,
        'allow_overlap = true\n[[recording]]\nfile = "run.csv"\nrole = "train"\nrows = [0, 2000]\n'
        '[[recording]]\nfile = "train.csv"\nrole = "validate"\nrows = [1500, 3000]\n'
        '[[recording]]\nfile = "run.csv"\nrole = "validate"\nrows = [1900, 3000]\n',
        "overlap.toml",
    )
    with pytest.warns(UserWarning) as caught:
        study = Manifest.load(path).read(m)
    said = " ".join(str(w.message) for w in caught)
    assert "share rows 1900–1999" in said and "share 500 samples (the same t, q and tau in train.csv" in said
    assert [ds.n for ds in study.train] == [2000] and [ds.n for ds in study.validate] == [1500, 1100]


def test_cli_manifest_and_its_errors(one_file, tmp_path):
    m, folder = one_file
    study = _write(
        folder, '[[recording]]\nfile = "run.csv"\nrole = "train"\nrows = [0, 3200]\nfit_joint = 1\n', "c.toml"
    )
    out = tmp_path / "out"
    proc = run_cli("identify", "--manifest", str(study), "--methods", "ols", "-o", str(out), "--no-report")
    assert_clean_error(proc, "unknown key(s) fit_joint in [[recording]] 1")
    assert not out.exists()
    good = _write(folder, '[[recording]]\nfile = "run.csv"\nrole = "train"\nrows = [0, 3200]\n', "d.toml")
    both = argparse.Namespace(manifest=str(good), data=["run.csv"], validate=[], fit_joints=None, delay=None)
    with pytest.raises(SpecError, match="without --data/--validate/--mapping"):
        recording_options(both)
    with pytest.raises(SpecError, match="and mapping given too"):
        identify(Study.from_manifest(good, m, mapping=folder / "x.toml"))
    with pytest.raises(SpecError, match="expected --data FILE"):
        recording_options(argparse.Namespace(**{**vars(both), "manifest": None, "data": None}))
    past = _write(folder, '[[recording]]\nfile = "run.csv"\nrole = "train"\nrows = [3000, 400000]\n', "e.toml")
    proc = run_cli("identify", "--manifest", str(past), "--methods", "ols", "-o", str(out), "--no-report")
    assert_clean_error(proc, "go past the end of run.csv, which has 4800 rows")
    assert not out.exists()
    proc = run_cli("identify", "--manifest", str(good), "--methods", "ols", "-o", str(out), "--no-report")
    assert proc.returncode == 0, proc.stderr
    assert (out / "identification.json").is_file()


# ---------------------------------------------------------------------------------------------- fit joints
def test_fit_joints_leaves_out_exactly_those_rows():
    m = truth_model("ur5")
    ds = twin(m, seconds=8, rate=100, seed=2, noise=0.05)
    fit = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_3_joint"]
    res = identify(Study(m, ds, fit_joints=",".join(fit)), methods="ols")
    full = IdentificationProblem.from_datasets(m, ds)  # every row, the same rest rule
    left = m.joint_names.index("wrist_2_joint")
    keep = full.joint != left
    part = IdentificationProblem.from_datasets(m, ds, fit_joints=fit)
    assert np.array_equal(part.tau, full.tau[keep]) and np.array_equal(part.sample, full.sample[keep])
    assert res.data["fit_joints"] == fit and res.data["rows"] == int(keep.sum())
    # by hand: the standard regressor's rows of the fitted joints, the base columns, least squares
    base = part.base
    assert "wrist_2_joint.fc" not in base.names  # only its own row would show it
    W = regressor(m, ds.q, ds.dq, ds.ddq)[:, base.independent]
    rows = full.sample[keep] * m.nv + full.joint[keep]
    x = np.linalg.lstsq(W[rows], full.tau[keep], rcond=None)[0]
    assert np.allclose(res["ols"].base, x, rtol=1e-9, atol=1e-10)


def test_base_parameters_of_fitted_rows_round_trip():
    from pinid.model.base import BaseParameters

    m = truth_model("exo_leg")
    bp = base_parameters(m, joints=["knee"])
    back = BaseParameters.from_dict(bp.to_dict())
    assert back.fit_joints == ["knee"] and back.names == bp.names and np.array_equal(back.P, bp.P)
    assert base_parameters(m, joints=["hip", "knee"]).fit_joints is None  # every joint: the usual set


def test_fit_joints_unknown_joint_names_the_joints():
    m = truth_model("exo_leg")
    with pytest.raises(SpecError, match="'ankle' is not an active joint.*expected some of hip, knee"):
        identify(Study(m, twin(m, seconds=2), fit_joints="knee,ankle"), methods="ols")


def test_left_out_joint_is_predicted_from_the_fitted_rows():
    """exo_leg fitted on the knee rows only: the hip (its torque channel unused) is predicted from the knee's
    identified parameters and the nominal values of what the knee rows cannot see."""
    m = truth_model("exo_leg")
    res = identify(
        Study(m, twin(m, seconds=20, seed=1, noise=0.05), validate=twin(m, seconds=10, seed=2), fit_joints=["knee"]),
        methods="ols",
    )
    assert res["ols"].base_names == ["knee.mx", "knee.mz", "knee.Iyy", "knee.fc", "knee.fv"]
    assert res["ols"].validation.per_joint["hip"]["rel_rms_percent"] < 0.1  # the nominal model is the truth here
    assert "fit joints: knee (torque rows of hip left out; still predicted)" in identification_text(res)


# ---------------------------------------------------------------------------------------------- delay
def _lagging(ds: Dataset, k: int) -> Dataset:
    """The recording with its torque channels recorded ``k`` samples late."""
    tau = np.vstack([np.repeat(ds.tau[:1], k, axis=0), ds.tau[:-k]])
    return Dataset(ds.t, ds.q, ds.joints, dq=ds.dq, ddq=ds.ddq, tau=tau, source="lagging")


@pytest.mark.parametrize("name,k,rate", [("exo_leg", 8, 200.0), ("ur5", 13, 250.0)])
def test_estimated_delay_recovers_a_known_delay_to_one_sample(name, k, rate):
    m = truth_model(name)
    ds = _lagging(twin(m, seconds=20, rate=rate, seed=4, noise=0.05), k)
    found = estimate_delay(m, [ds])["delay"]
    assert abs(found - k / rate) <= 1 / rate, (found, k / rate)
    res = identify(
        Study(m, ds, validate=_lagging(twin(m, seconds=6, rate=rate, seed=5), k), delay="auto"), methods="ols"
    )
    assert res.data["delay"]["estimated"] and abs(res.data["delay"]["delay"] - k / rate) <= 1 / rate
    assert "torque delay behind the positions: " in identification_text(res)


def test_given_delay_of_whole_samples_moves_the_samples():
    m = truth_model("exo_leg")
    ds = twin(m, seconds=4, rate=200, seed=1)
    moved = shift_torque(_lagging(ds, 6), parse_delay("tau=0.03", m.joint_names))
    assert np.array_equal(moved.tau, ds.tau[:-6]) and np.array_equal(moved.q, ds.q[:-6])
    assert np.array_equal(parse_delay("tau.knee=0.02", m.joint_names), [0.0, 0.02])
    for bad in ("tau=soon", "tau.ankle=0.1", "tau=1e3", "tau.knee=auto"):
        with pytest.raises(SpecError):
            parse_delay(bad, m.joint_names)
    with pytest.raises(SpecError, match=r"knee given twice \(tau.knee=0.04, knee=0.02\); expected each channel once"):
        parse_delay("tau.knee=0.04,knee=0.02", m.joint_names)  # issue 33: the last one won, silently
    with pytest.raises(SpecError, match="tau given twice"):
        parse_delay("tau=0.04,tau=0.02", m.joint_names)
    assert np.array_equal(parse_delay("tau.knee=0.02,tau=0.04", m.joint_names), [0.04, 0.02])  # in any order


def test_given_delay_moves_the_raw_yardstick_too():
    """Issue 33 (01): with the true delay the raw errors (against the torque as recorded, aligned by the same
    delay, not filtered) are those of the undelayed recording; before, they were measured against the
    unshifted torque: 4.42 % against 0.68 %."""
    m = truth_model("exo_leg")
    train, valid = twin(m, seconds=12, rate=200, seed=4, noise=0.05), twin(m, seconds=6, rate=200, seed=5, noise=0.05)
    ref = identify(Study(m, train, validate=valid, preprocess=True), methods="ols")["ols"]
    got = identify(
        Study(m, _lagging(train, 8), validate=_lagging(valid, 8), preprocess=True, delay="tau=0.04"), methods="ols"
    )["ols"]
    for a, b in ((got.validation, ref.validation), (got.train, ref.train)):
        assert a.all["rel_rms_percent"] == pytest.approx(b.all["rel_rms_percent"], rel=0.03)


# ---------------------------------------------------------------------------------------------- vendor URDFs
LINK = """<link name="{name}"><inertial><origin xyz="0 0 -0.2"/><mass value="{mass}"/>
  <inertia ixx="{ixx}" iyy="{iyy}" izz="{izz}" ixy="0" ixz="0" iyz="0"/></inertial></link>"""
JOINT = """<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>
  <origin xyz="0 0 -0.4"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="100" velocity="3"/>{extra}</joint>"""


def _urdf(tmp_path, inertia=(0.02, 0.03, 0.01), mimic=False):
    links = [
        '<link name="base"/>',
        LINK.format(name="a", mass=2.0, ixx=0.05, iyy=0.05, izz=0.01),
        LINK.format(name="b", mass=1.0, ixx=inertia[0], iyy=inertia[1], izz=inertia[2]),
        LINK.format(name="c", mass=0.1, ixx=1e-4, iyy=1e-4, izz=1e-4),
    ]
    joints = [
        JOINT.format(name="j1", parent="base", child="a", extra=""),
        JOINT.format(name="j2", parent="a", child="b", extra=""),
        JOINT.format(name="j3", parent="b", child="c", extra='<mimic joint="j2" multiplier="1"/>' if mimic else ""),
    ]
    p = tmp_path / "arm.urdf"
    p.write_text('<robot name="arm">' + "".join(links + joints) + "</robot>")
    return p


def test_unphysical_inertia_refused_by_default_repaired_on_request(tmp_path):
    path = _urdf(tmp_path, inertia=(0.01, 0.01, 0.05))  # 0.05 > 0.01 + 0.01: triangle inequality broken
    with pytest.raises(ModelError, match="--repair-inertia"):
        RobotModel.from_urdf(path)
    with pytest.warns(ModelWarning, match="joint 'j2'.*repaired to the nearest physical inertia") as caught:
        m = RobotModel.from_urdf(path, repair_inertia=True)
    assert len([w for w in caught if issubclass(w.category, ModelWarning)]) == 1  # one line per repaired body
    e = np.linalg.eigvalsh(m.pin_model.inertias[2].inertia)
    assert e[2] <= e[0] + e[1] + 1e-12 and np.allclose(e, [0.02, 0.02, 0.04])  # (0.01, 0.01, 0.05) projected
    assert m.pin_model.inertias[2].mass == 1.0 and np.allclose(m.pin_model.inertias[2].lever, [0, 0, -0.2])
    proc = run_cli("info", "--urdf", str(path), "--repair-inertia")
    assert proc.returncode == 0 and proc.stderr.count("\n") == 1 and "repaired" in proc.stderr, proc.stderr


def test_nearest_physical_inertia_is_the_nearest():
    rng = np.random.default_rng(0)
    for _ in range(20):
        A = rng.normal(size=(3, 3))
        I = A @ A.T + np.diag(rng.uniform(-1, 3, 3))  # often not physical
        fixed = nearest_physical_inertia(I)
        e = np.linalg.eigvalsh(fixed)
        assert e[0] >= -1e-12 and e[2] <= e[0] + e[1] + 1e-9
        dist = np.linalg.norm(fixed - I)
        for _ in range(200):  # no physical inertia is nearer (random ones around the answer)
            B = rng.normal(size=(3, 3)) * 0.3
            cand = fixed + 0.5 * (B + B.T)
            c = np.linalg.eigvalsh(cand)
            if c[0] >= 0 and c[2] <= c[0] + c[1]:
                assert np.linalg.norm(cand - I) >= dist - 1e-9
        if np.all(np.linalg.eigvalsh(I) >= 0) and (lambda v: v[2] <= v[0] + v[1])(np.linalg.eigvalsh(I)):
            assert np.allclose(fixed, I)


def test_mimic_joint_is_locked_without_joints(tmp_path):
    path = _urdf(tmp_path, mimic=True)
    m = RobotModel.from_urdf(path)
    assert m.joint_names == ["j1", "j2"] and m.locked == {"j3": 0.0}
    with pytest.raises(ModelError, match="mimic"):
        RobotModel.from_urdf(path, joints=["j1", "j2", "j3"])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert RobotModel.from_urdf(_urdf(tmp_path)).joint_names == ["j1", "j2", "j3"]


# ---------------------------------------------------------------------------------------------- the coupled joint
def test_coupled_motor_at_rest_drops_the_rows_of_its_joints(monkeypatch):
    """A differential wrist (motor 6 turns with q5 + q6) with noisy measured velocities: motor 6's Coulomb
    column sign(dq5 + dq6) flips where the motor is at rest, whatever the joints do; those rows are left out
    (of both its joints), and the coupled joint is then predicted ≥ 3× better than without the motor rule
    (measured 6–12× on three seeds)."""
    import pinid.problem.problem as problem

    m = coupled("ur5")
    clean = drive_twin(m, MOTOR_TERMS, seconds=30, rate=250, seed=11)
    noise = np.random.default_rng(1).normal(size=clean.dq.shape) * 0.02
    train = Dataset(clean.t, clean.q, clean.joints, dq=clean.dq + noise, ddq=clean.ddq, tau=clean.tau, source="t")
    valid = drive_twin(m, MOTOR_TERMS, seconds=10, rate=250, seed=51)
    G = m.drives.matrix
    vm = train.dq @ G.T
    still = np.abs(vm) < rest_thresholds(vm)  # (N, motors) at rest
    keep = motor_kept_rows(train, m, MOTOR_TERMS).reshape(-1, m.nv)
    assert still[:, 5].any() and not keep[still[:, 5], 4:].any()  # motor 6 at rest: rows of q5 and q6 out
    assert np.array_equal(keep, ~((still @ (G != 0)) > 0))  # and nothing else than motors at rest
    new = identify(Study(m, train, validate=valid, terms=MOTOR_TERMS), methods="ols")
    monkeypatch.setattr(problem, "motor_kept_rows", lambda ds, *a, **k: np.ones(ds.dq.size, bool))
    old = identify(Study(m, train, validate=valid, terms=MOTOR_TERMS), methods="ols")
    j = "wrist_3_joint"
    assert 3 * new["ols"].validation.per_joint[j]["rms"] <= old["ols"].validation.per_joint[j]["rms"]
    bp = base_parameters(m, MOTOR_TERMS)
    truth = bp.from_standard(standard_parameters(m, MOTOR_TERMS))
    i = bp.names.index("m6.fc")
    assert abs(new["ols"].base[i] - truth[i]) <= 0.02 * truth[i] < abs(old["ols"].base[i] - truth[i])


def test_documented_study_manifest_on_the_real_double_pendulum(tmp_path):
    """docs/examples/study/double_pendulum_study.toml beside the shared recordings, as docs/data.md says."""
    import shutil
    from pathlib import Path

    from conftest import shared_data

    data = shared_data()
    if not (data / "double_pendulum").is_dir():
        pytest.skip("no shared double-pendulum recordings")
    docs = Path(__file__).resolve().parents[2] / "docs" / "examples"
    for name in ("trajectory_00.csv", "trajectory_01.csv", "trajectory_02.csv"):
        (tmp_path / name).symlink_to(data / "double_pendulum" / name)
    shutil.copy(docs / "double_pendulum.toml", tmp_path)
    shutil.copy(docs / "study" / "double_pendulum_study.toml", tmp_path)
    model = RobotModel.from_urdf(data / "double_pendulum" / "double_pendulum.urdf")
    study = Manifest.load(tmp_path / "double_pendulum_study.toml").read(model)
    assert [ds.t[-1] < 7.0 for ds in study.train] == [False, True]
    assert study.validate[0].t[0] >= 7.0 and len(study.validate) == 2
    res = identify(
        Study.from_manifest(tmp_path / "double_pendulum_study.toml", model, terms="fc,fv,armature"), methods="ols"
    )
    assert res.validation_sources[0].endswith("trajectory_01.csv[t 7–10 s]")
