"""Identification with a floating base and contacts (issue 27): the twin, the data format, the estimators."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from conftest import floating_excitation
from pinid.errors import DataWarning, SolverError, SpecError
from pinid.identification.run import identify
from pinid.identification.study import Study
from pinid import DataError, RobotModel
from pinid.data.formats import read_recording, write_recording
from pinid.data.preprocess import prepare
from pinid.estimators import ESTIMATORS, make_estimator
from pinid.problem.floating import floating_problem
from pinid.model.base import base_parameters
from pinid.model.terms import TermSelection
from pinid.simulation.floating_twin import simulate_gait, simulate_suspended

TERMS = TermSelection.from_names("fc,fv")


@pytest.fixture(scope="module")
def suspended(floating_exo):
    return simulate_suspended(floating_exo, floating_excitation(floating_exo), seconds=5, rate=200, imu_frame="imu")


@pytest.fixture(scope="module")
def gait(floating_exo):
    return simulate_gait(floating_exo, seconds=3, rate=200)


def error(problem, estimate):
    """Largest error of the base parameters relative to their natural scale (mass, mass·length, mass·length²)."""
    return float(np.max(np.abs(estimate - problem.nominal_base) / problem.natural_scale))


@pytest.mark.parametrize("method", ["ols", "sdp"])
@pytest.mark.parametrize("rows", ["all", "base"])
def test_suspended_twin_recovers_the_base_parameters(floating_exo, suspended, method, rows):
    """Noise-free suspended twin: joint torques + harness wrench (rows all), or the wrench and motion alone (rows base)."""
    problem = floating_problem(floating_exo, suspended.exact, terms=TERMS, rows=rows)
    # OLS is exact to rounding; SDP to its interior-point solver's tolerance, which moves between releases
    # (1.5e-6 with cvxpy 1.9.3 and Clarabel 0.11.1, under 1e-6 before)
    assert error(problem, make_estimator(method).fit(problem).base_) <= (1e-6 if method == "ols" else 5e-6)
    if rows == "base":  # Ayusawa et al. 2014: the base rows identify every inertial base parameter
        assert problem.nb == base_parameters(floating_exo, TermSelection.from_names("none")).count
        assert problem.names[0] == "base.mR"  # the total mass among them


@pytest.mark.parametrize("method", ["ols", "sdp"])
def test_gait_twin_recovers_the_base_parameters(floating_exo, gait, method):
    problem = floating_problem(floating_exo, gait.exact, terms=TERMS)
    # OLS is exact to rounding; SDP to its interior-point solver's tolerance, which moves between releases
    # (1.5e-6 with cvxpy 1.9.3 and Clarabel 0.11.1, under 1e-6 before)
    assert error(problem, make_estimator(method).fit(problem).base_) <= (1e-6 if method == "ols" else 5e-6)
    left, right = (gait.recording.floating.contacts[s] for s in ("l_sole", "r_sole"))
    assert (left & right).any() and (left & ~right).any() and (right & ~left).any()  # double and single support


def test_gait_double_support_split_sums_to_the_total_wrench(floating_exo, gait):
    """The two soles' wrenches carry exactly what the motion needs (the base rows of the RNEA)."""
    from pinid.problem.floating import floating_targets

    s = gait.exact
    tau_free = s.data.tau
    s.data.tau = None
    try:
        y = floating_targets(floating_exo, s)
    finally:
        s.data.tau = tau_free
    from pinid.model.floating import floating_rnea

    rnea = floating_rnea(floating_exo, s.base_q, s.base_v, s.base_a, s.data.q, s.data.dq, s.data.ddq)
    np.testing.assert_allclose(y[:, :6], rnea[:, :6], atol=1e-8 * np.abs(rnea[:, :6]).max())


@pytest.mark.parametrize(
    "method", [pytest.param(m, marks=pytest.mark.slow) if m == "logdet" else m for m in sorted(ESTIMATORS)]
)  # logdet: 3.5 s (its cross-validation)
def test_every_estimator_takes_the_floating_problem(floating_exo, method):
    """Every registered estimator fits the floating problem (the population ones briefly); the least-squares
    family recovers the noise-free walk."""
    problem = floating_problem(floating_exo, simulate_gait(floating_exo, seconds=2, rate=100).exact, terms=TERMS)
    settings = {"iterations": 5, "population": 10} if method in ("pso", "woa", "ewoa", "de") else {}
    if ESTIMATORS[method].simulates:  # iv, didim simulate a fixed-base robot: refused with one line
        with pytest.raises(SpecError, match="floating base"):
            make_estimator(method, **settings).fit(problem)
        return
    try:
        est = make_estimator(method, **settings).fit(problem)
    except SolverError as exc:  # logdet on the oldest cvxpy admitted (1.5): one line naming the cause, no crash
        if method == "logdet" and "int32 overflow" in str(exc):
            pytest.skip(str(exc))
        raise
    assert est.base_.shape == (problem.nb,) and np.all(np.isfinite(est.base_))
    if method in ("ols", "wls", "sdp", "rls", "ridge", "rls-pso"):
        assert error(problem, est.base_) <= 1e-6


def test_recording_round_trip_and_imu(floating_exo, suspended, tmp_path):
    """Written, read back and filtered: the base rows give the total mass to 0.5 %, from an IMU and a load cell."""
    path = write_recording(tmp_path / "s.csv", suspended.recording)
    rec = read_recording(path, model=floating_exo)
    assert rec.floating.imu_frame == "imu" and list(rec.floating.wrenches) == ["pelvis"]
    np.testing.assert_allclose(
        rec.floating.wrenches["pelvis"], suspended.recording.floating.wrenches["pelvis"], rtol=1e-10, atol=1e-9
    )
    samples = prepare(rec, {"cutoff": 20.0})
    problem = floating_problem(floating_exo, samples, rows="base")
    base = make_estimator("ols").fit(problem).base_
    assert base[0] == pytest.approx(21.8, rel=5e-3)


def test_a_floating_recording_is_one_dataset_in_memory_and_on_disk(floating_exo, suspended, tmp_path):
    """One recording type (issue 32): the twin's recording is a Dataset with floating channels; written and read
    back it writes the same bytes; ``select`` cuts its channels with the joints; identify takes it as it takes its
    file (the same base parameters, exactly)."""
    rec = suspended.recording
    path = write_recording(tmp_path / "s.csv", rec)
    back = read_recording(path, model=floating_exo)
    assert back.floating.model is floating_exo and "imu_imu_wx" not in back.meta.get("ignored_columns", [])
    assert write_recording(tmp_path / "again.csv", back).read_bytes() == path.read_bytes()
    part = back.select(slice(100, 400))
    assert part.n == 300 and part.floating.wrenches["pelvis"].shape == (300, 6)
    np.testing.assert_array_equal(part.floating.imu["w"], back.floating.imu["w"][100:400])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from_file = identify(Study(floating_exo, path, terms=TermSelection()), methods=["ols"])
        from_memory = identify(Study(floating_exo, [back], terms=TermSelection()), methods=["ols"])
    np.testing.assert_array_equal(from_file.results["ols"].base, from_memory.results["ols"].base)
    with pytest.raises(SpecError, match="swing_rows: only for a floating model"):
        read_recording(path, model=RobotModel.from_urdf("exo_lower_body"), swing_rows=True)


def _csv(tmp_path, header, row):
    p = tmp_path / "bad.csv"
    joints = [f"q_{j}" for j in RobotModel.from_urdf("exo_lower_body").joint_names]
    lines = [",".join(["t", *joints, *header])]
    lines += [",".join([str(0.01 * k), *["0.1"] * len(joints), *[str(v) for v in row]]) for k in range(20)]
    p.write_text("\n".join(lines) + "\n")
    return p


POSE = ["base_x", "base_y", "base_z", "base_qx", "base_qy", "base_qz", "base_qw"]


@pytest.mark.parametrize(
    "header, row, fragment",
    [
        (
            POSE + [f"wrench_nowhere_{c}" for c in ("fx", "fy", "fz", "tx", "ty", "tz")],
            [0] * 6 + [1] + [0] * 6,
            "'nowhere' is not a link",
        ),
        (
            ["imu_ghost_" + c for c in ("qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az")],
            [0, 0, 0, 1] + [0] * 6,
            "'ghost' is not a link",
        ),
        (
            ["imu_l_thigh_" + c for c in ("qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az")],
            [0, 0, 0, 1] + [0] * 6,
            "not fixed to the base link",
        ),
        (POSE, [0, 0, 0, 0.5, 0, 0, 0.5], "expected a unit quaternion"),
        (POSE + ["contact_l_sole"], [0] * 6 + [1, 1], "no wrench_l_sole_* or plate_l_sole_*"),
        (
            ["imu_imu_" + c for c in ("qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az")]
            + [f"plate_l_sole_{c}" for c in ("fx", "fy", "fz", "copx", "copy")],
            [0, 0, 0, 1] + [0] * 11,
            "need the base position",
        ),
        ([], [], "no base motion"),
    ],
)
def test_bad_floating_recordings(floating_exo, tmp_path, header, row, fragment):
    with pytest.raises(DataError, match=fragment.replace("*", r"\*")):
        read_recording(_csv(tmp_path, header, row), model=floating_exo)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["suspended", "gait"])
def test_noisy_twin_validates_at_the_noise_floor(floating_exo, kind, tmp_path):
    """Noisy twin through files, filtering and differentiation: on a held-out recording the identified model's
    RMS is within 5 % of the true parameters' own RMS (the noise floor on that data); the SDP is consistent."""
    from pinid.model.physical import check_consistency
    from pinid.simulation.floating_twin import Noise

    noise = Noise(2e-5, 0.3, 2.0, 0.2, 0.005, 0.05)
    if kind == "suspended":
        runs = [
            simulate_suspended(
                floating_exo, floating_excitation(floating_exo, k), seconds=8, rate=250, noise=noise, seed=k
            )
            for k in (0, 1)
        ]
    else:
        runs = [simulate_gait(floating_exo, seconds=10, rate=500, noise=noise, seed=1)]
        runs.append(
            simulate_gait(floating_exo, seconds=6, rate=500, noise=noise, seed=2, pattern={"period": 1.0, "speed": 0.9})
        )
    samples = []
    for k, run in enumerate(runs):
        path = write_recording(tmp_path / f"{k}.csv", run.recording)
        samples.append(prepare(read_recording(path, model=floating_exo)))
    train = floating_problem(floating_exo, samples[0], terms=TERMS)
    held = floating_problem(floating_exo, samples[1], terms=TERMS, base=train.base)
    floor = np.sqrt(np.mean((held.tau - held.predict(held.nominal_base)) ** 2))
    for method in ("ols", "sdp"):
        est = make_estimator(method).fit(train)
        rms = np.sqrt(np.mean((held.tau - held.predict(est.base_)) ** 2))
        assert rms <= 1.05 * floor, (method, rms, floor)
    assert check_consistency(est.standard_, train.model.joint_names, train.terms.names, []).consistent


def test_swing_rows_of_a_leg_without_force_sensing(floating_exo, tmp_path):
    """The right foot's wrench unknown (contact phases only): its contact rows are left out, and the rest still
    recovers the noise-free walk; from a file, --swing-rows accepts what is otherwise refused."""
    import dataclasses

    run = simulate_gait(floating_exo, seconds=6, rate=200)
    right = run.recording.floating.contacts["r_sole"]
    s = dataclasses.replace(
        run.exact, wrenches=[w for w in run.exact.wrenches if w.link == "l_sole"], unsensed={"r_sole": right}
    )
    problem = floating_problem(floating_exo, s, terms=TERMS)
    assert problem.rows == s.n * 14 - int(right.sum()) * (6 + 4)  # base rows and the right leg's 4 joints
    assert error(problem, make_estimator("ols").fit(problem).base_) <= 1e-6
    rec = run.recording
    rec.floating.plates.pop("r_sole")
    path = write_recording(tmp_path / "g.csv", rec)
    with pytest.raises(DataError, match="--swing-rows"):
        read_recording(path, model=floating_exo)
    samples = prepare(read_recording(path, model=floating_exo, swing_rows=True))
    assert set(samples.unsensed) == {"r_sole"} and samples.unsensed["r_sole"].sum() >= right[: samples.n].sum() * 0.9


def test_no_joint_torque_uses_the_base_rows_only(floating_exo, suspended, tmp_path):
    """The wearer's case: no tau_ columns; --rows base identifies from the harness wrench and the IMU, joint rows
    are refused with a one-line reason."""
    import dataclasses

    rec = dataclasses.replace(suspended.recording, tau=None)
    samples = prepare(read_recording(write_recording(tmp_path / "w.csv", rec), model=floating_exo), {"cutoff": 20.0})
    assert samples.data.tau is None
    base = make_estimator("ols").fit(floating_problem(floating_exo, samples, rows="base")).base_
    assert base[0] == pytest.approx(21.8, rel=5e-3)
    with pytest.raises(DataError, match="only the base rows can be used"):
        floating_problem(floating_exo, samples, rows="all")
    # identify with the default rows: the base rows alone, said in one line (issue 46); rows="joints" is refused
    with pytest.warns(DataWarning, match=r"no joint torque \(tau_<joint> columns\): the 6 base rows alone are used"):
        ident = identify(Study(floating_exo, tmp_path / "w.csv", preprocess={"cutoff": 20.0}), methods=("ols",))
    assert ident.data["rows"] == "base" and ident.results["ols"].base[0] == pytest.approx(base[0], rel=1e-9)
    with pytest.raises(DataError, match="only the base rows can be used"):
        identify(Study(floating_exo, tmp_path / "w.csv", floating={"rows": "joints"}), methods=("ols",))


def test_rest_rows_left_out_on_request(floating_exo, gait):
    problem = floating_problem(floating_exo, gait.exact, terms=TERMS, rest_velocity=0.05)
    slow = int((np.abs(gait.exact.data.dq) < 0.05).sum())
    assert slow > 0 and problem.rows == gait.exact.n * 14 - slow
    assert error(problem, make_estimator("ols").fit(problem).base_) <= 1e-6


@pytest.mark.parametrize("raw_topic", [False, True])
def test_ros2_bag_with_imu_and_wrench_messages(floating_exo, suspended, tmp_path, raw_topic):
    """JointState + sensor_msgs/Imu (frame "imu") + geometry_msgs/WrenchStamped (frame "pelvis") in a rosbag2
    folder read as the same floating recording as the CSV (Imu and wrench interpolated onto the joint stamps).
    ``raw_topic``: a second WrenchStamped topic in the same frame (a F/T driver's uncompensated /harness_raw,
    +50 N, 0.3 ms later) was merged into the wrench series (round 4 finding 10: total mass 24 kg instead of
    21.8); now refused in one line naming both topics, and ``[ros] ignore_topics`` chooses one."""
    pytest.importorskip("rosbags")
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.LATEST)
    T = store.types
    rec = suspended.recording
    ds = rec
    t0 = 1_700_000_000_000_000_000

    def header(ns, frame=""):
        return T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9), frame_id=frame
        )

    def vec(x):
        return T["geometry_msgs/msg/Vector3"](x=float(x[0]), y=float(x[1]), z=float(x[2]))

    path = tmp_path / "bag"
    js, imu, wr = "sensor_msgs/msg/JointState", "sensor_msgs/msg/Imu", "geometry_msgs/msg/WrenchStamped"
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        cj, ci, cw = (
            w.add_connection(t, m, typestore=store) for t, m in (("/joint_states", js), ("/imu", imu), ("/harness", wr))
        )
        cw2 = w.add_connection("/harness_raw", wr, typestore=store) if raw_topic else None
        for k, tk in enumerate(ds.t):
            ns = t0 + int(round(tk * 1e9))
            w.write(
                cj,
                ns,
                store.serialize_cdr(
                    T[js](header=header(ns), name=ds.joints, position=ds.q[k], velocity=np.zeros(0), effort=ds.tau[k]),
                    js,
                ),
            )
            q, g, a = rec.floating.imu["q"][k], rec.floating.imu["w"][k], rec.floating.imu["a"][k]
            orient = T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])
            zero9 = np.zeros(9)
            msg = T[imu](
                header=header(ns, "imu"),
                orientation=orient,
                orientation_covariance=zero9,
                angular_velocity=vec(g),
                angular_velocity_covariance=zero9,
                linear_acceleration=vec(a),
                linear_acceleration_covariance=zero9,
            )
            w.write(ci, ns, store.serialize_cdr(msg, imu))
            f = rec.floating.wrenches["pelvis"][k]
            msg = T[wr](
                header=header(ns, "pelvis"), wrench=T["geometry_msgs/msg/Wrench"](force=vec(f[:3]), torque=vec(f[3:]))
            )
            w.write(cw, ns, store.serialize_cdr(msg, wr))
            if raw_topic:
                g = f + np.array([0, 0, 50.0, 0, 0, 0])
                msg = T[wr](
                    header=header(ns + 300_000, "pelvis"),
                    wrench=T["geometry_msgs/msg/Wrench"](force=vec(g[:3]), torque=vec(g[3:])),
                )
                w.write(cw2, ns + 300_000, store.serialize_cdr(msg, wr))
    mapping = None
    if raw_topic:
        with pytest.raises(SpecError, match=r"topics /harness and /harness_raw both give the wrench_pelvis_\* col"):
            read_recording(path, model=floating_exo)
        side = [f"imu_imu_{c}" for c in ("qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az")]
        side += [f"wrench_pelvis_{c}" for c in ("fx", "fy", "fz", "tx", "ty", "tz")]
        mapping = {
            "ros": {"ignore_topics": ["/harness_raw"]},
            "joints": {j: {"q": f"q_{j}", "tau": f"tau_{j}"} for j in ds.joints},
            "floating": {c: c for c in side},
        }
    from_bag = read_recording(path, model=floating_exo, mapping=mapping)
    from_csv = read_recording(write_recording(tmp_path / "s.csv", rec), model=floating_exo)
    assert from_bag.floating.imu_frame == "imu" and list(from_bag.floating.wrenches) == ["pelvis"]
    for key in ("q", "w", "a"):
        np.testing.assert_allclose(from_bag.floating.imu[key], from_csv.floating.imu[key], atol=1e-9)
    np.testing.assert_allclose(from_bag.floating.wrenches["pelvis"], from_csv.floating.wrenches["pelvis"], atol=1e-9)
    np.testing.assert_allclose(from_bag.tau, from_csv.tau, atol=1e-9)


def test_always_in_contact_and_base_weight_out_of_range_are_named(floating_exo):
    """Issue 33 (minor): a leg without force sensing in contact in every sample is named (in contact, not "at
    rest", not a list of unexcited columns); --base-weight 1e300 is out of range, not "columns are zero"."""
    import dataclasses

    run = simulate_gait(floating_exo, seconds=1, rate=100)
    s = dataclasses.replace(
        run.exact,
        wrenches=[w for w in run.exact.wrenches if w.link == "l_sole"],
        unsensed={"r_sole": np.ones(run.exact.n, bool)},
    )
    with pytest.raises(DataError, match="r_sole in contact in every sample without a measured wrench"):
        floating_problem(floating_exo, s, terms=TERMS)
    with pytest.raises(DataError, match=r"base_weight=1e\+300 is out of range, expected a number in \[1e-06, 1e\+06\]"):
        floating_problem(floating_exo, run.exact, terms=TERMS, base_weight=1e300)


def _edited(tmp_path, recording, name, edit):
    """The twin recording written, its columns edited by ``edit(names, array)`` in place, written as ``name``."""
    path = write_recording(tmp_path / f"{name}_src.csv", recording)
    names = path.read_text().splitlines()[0].split(",")
    a = np.loadtxt(path, delimiter=",", skiprows=1)
    names = edit(names, a) or names
    out = tmp_path / f"{name}.csv"
    np.savetxt(out, a, delimiter=",", header=",".join(names), comments="", fmt="%.12g")
    return out


def _flip_half(names, a):
    qi = [names.index(f"base_{c}") for c in ("qx", "qy", "qz", "qw")]
    a[len(a) // 2 :, qi] *= -1  # q -> -q: the same rotations, the other hemisphere


def test_quaternion_sign_flips_change_nothing(floating_exo, gait, tmp_path):
    """A base quaternion that jumps to −q (motion capture keeping w ≥ 0) gives the same parameters as without."""
    from pinid.identification.run import identify

    plain = _edited(tmp_path, gait.recording, "plain", lambda n, a: None)
    flipped = _edited(tmp_path, gait.recording, "flipped", _flip_half)
    a, b = (identify(Study(floating_exo, p), methods=["ols"]).results["ols"].base for p in (plain, flipped))
    np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-9 * np.max(np.abs(a)))


def test_given_joint_derivatives_do_not_skip_the_base_filter(floating_exo, gait, tmp_path):
    """dq_/ddq_ columns for the joints: the noisy base pose is still filtered (--preprocess auto), so the total
    mass stays at 21.8 kg; with preprocessing off, exact data leave no residual at the ends."""
    from pinid.identification.run import identify

    rng = np.random.default_rng(0)

    def noisy_with_derivatives(names, a):
        for c in ("base_x", "base_y", "base_z"):
            a[:, names.index(c)] += 1e-4 * rng.standard_normal(len(a))
        return None

    rec = gait.recording
    path = _edited(tmp_path, rec, "noisy", noisy_with_derivatives)
    text = path.read_text().splitlines()
    joints = rec.joints
    extra = np.hstack([gait.exact.data.dq, gait.exact.data.ddq])  # the twin's exact joint derivatives
    assert len(extra) == rec.n
    rows = [f"{line},{','.join(f'{v:.12g}' for v in e)}" for line, e in zip(text[1:], extra)]
    header = text[0] + "," + ",".join([f"dq_{j}" for j in joints] + [f"ddq_{j}" for j in joints])
    path.write_text("\n".join([header, *rows]) + "\n")
    r = identify(Study(floating_exo, path), methods=["ols"]).results["ols"]
    assert r.base[0] == pytest.approx(21.8, rel=2e-3)
    exact = _edited(tmp_path, rec, "exact", lambda n, a: None)
    text = exact.read_text().splitlines()
    exact.write_text(
        "\n".join([header, *[f"{line},{','.join(f'{v:.12g}' for v in e)}" for line, e in zip(text[1:], extra)]]) + "\n"
    )
    r = identify(Study(floating_exo, exact, preprocess=False), methods=["ols"]).results["ols"]
    assert r.train.per_joint["base"]["rms"] < 0.02  # [N, N·m]: no one-sided differences left at the ends
    assert r.base[0] == pytest.approx(21.8, rel=1e-3)


def _negate_plates(names, a):
    for i, c in enumerate(names):
        if c.startswith("plate_") and c.endswith(("_fx", "_fy", "_fz", "_tz")):
            a[:, i] *= -1  # the force of the foot on the plate


def _invert_phases(names, a):
    for i, c in enumerate(names):
        if c.startswith("contact_"):
            a[:, i] = 1 - a[:, i]


def _w_first(names, a):
    qi = [names.index(f"base_{c}") for c in ("qx", "qy", "qz", "qw")]
    a[:, qi] = a[:, [qi[3], qi[0], qi[1], qi[2]]]


def _millimetres(names, a):
    for c in ("base_x", "base_y", "base_z"):
        a[:, names.index(c)] *= 1000


@pytest.mark.parametrize(
    "edit, cause",
    [
        (_negate_plates, "the sign of the wrench"),
        (_invert_phases, r"check the phase logic \(1 = in contact\)"),
        (_w_first, r"quaternion order \(x, y, z, w expected, w last\)"),
        (_millimetres, r"units \(m expected, not mm\)"),
    ],
)
def test_implausible_total_mass_names_the_cause(floating_exo, gait, tmp_path, edit, cause):
    """A convention error in the recording never passes silently: an error (or a warning) naming the cause."""
    from pinid.identification.run import identify

    import re

    path = _edited(tmp_path, gait.recording, "bad", edit)
    said = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            identify(Study(floating_exo, path), methods=["ols", "sdp"])
        except DataError as exc:
            said.append(str(exc))
    said += [str(w.message) for w in caught]
    assert any(re.search(cause, line) for line in said), said


def test_accelerometer_without_gravity_is_named(floating_exo, suspended, tmp_path):
    from pinid.identification.run import identify

    def no_gravity(names, a):
        qi = [names.index(f"imu_imu_{c}") for c in ("qx", "qy", "qz", "qw")]
        ai = [names.index(f"imu_imu_{c}") for c in ("ax", "ay", "az")]
        from pinid.data.contacts import quat_matrix

        a[:, ai] -= np.einsum("nji,j->ni", quat_matrix(a[:, qi]), [0, 0, 9.81])  # specific force + R^T g

    path = _edited(tmp_path, suspended.recording, "nog", no_gravity)
    with pytest.warns(UserWarning, match="must include gravity"):
        with pytest.raises(DataError, match="likely cause: .*must include gravity"):
            identify(Study(floating_exo, path, floating={"rows": "base"}), methods=["ols"])


def test_no_wrench_in_the_base_rows_is_refused(floating_exo, suspended, tmp_path):
    from pinid.identification.run import identify

    path = write_recording(tmp_path / "src.csv", suspended.recording)
    names = path.read_text().splitlines()[0].split(",")
    a = np.loadtxt(path, delimiter=",", skiprows=1)
    keep = [i for i, c in enumerate(names) if not c.startswith(("wrench_", "plate_", "contact_"))]
    out = tmp_path / "nowrench.csv"
    np.savetxt(out, a[:, keep], delimiter=",", header=",".join(names[i] for i in keep), comments="", fmt="%.12g")
    with pytest.raises(DataError, match=r"no external wrench and no joint torque .*homogeneous"):
        identify(Study(floating_exo, out, floating={"rows": "base"}), methods=["ols"])


def test_setup_is_the_floating_bases_one_setup_path(floating_exo, suspended, tmp_path):
    """setup(study) of a floating robot stacks its rows (Setup.floating holds the validation rows and the raw
    recordings' hints), as identify and compare use it; what it cannot do is refused before anything is read."""
    from pinid.identification.run import setup

    s = setup(Study(floating_exo, data=[suspended.exact], terms=TERMS))
    assert s.floating is not None and s.problem is s.floating.problem and s.floating.validation is None
    assert s.problem.rows == suspended.exact.n * (6 + floating_exo.nv) and s.problem.names[0] == "base.mR"
    missing = str(tmp_path / "never_read.csv")
    with pytest.raises(SpecError, match=r"^fit_joints \(--fit-joints\): not available with a floating base"):
        setup(Study(floating_exo, data=missing, fit_joints=["l_knee"]))
    with pytest.raises(SpecError, match="Stribeck velocity 'auto': not available with a floating base"):
        setup(Study(floating_exo, data=missing), stribeck_auto={"fs": False})
