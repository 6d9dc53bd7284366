"""ROS 2 bags (pinid.data.rosbag): twin recordings written as rosbag2 folders (MCAP and sqlite3) and plain
.mcap files by rosbags itself read back as the same Dataset and identify to the same parameters."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from conftest import assert_clean_error, load, run_cli

pytest.importorskip("rosbags")

from rosbags.rosbag2 import StoragePlugin, Writer  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402

from pinid import identify  # noqa: E402
from pinid.identification.study import Study
from pinid.data.dataset import Dataset  # noqa: E402
from pinid.data.formats import read_recording  # noqa: E402
from pinid.errors import DataError, SpecError  # noqa: E402

STORE = get_typestore(Stores.LATEST)
JS = "sensor_msgs/msg/JointState"
T0_NS = 1_700_000_000_123_456_789  # a real epoch: the reader's t starts at 0 anyway


def _msg(ns: int, names, position=(), velocity=(), effort=()):
    types = STORE.types
    stamp = types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
    return types[JS](
        header=types["std_msgs/msg/Header"](stamp=stamp, frame_id=""),
        name=list(names),
        position=np.asarray(position, float),
        velocity=np.asarray(velocity, float),
        effort=np.asarray(effort, float),
    )


def write_bag(
    path, ds: Dataset, *, storage=StoragePlugin.MCAP, topic="/joint_states", effort_topic=None, names=None, extra=()
):
    """``ds`` as JointState messages (one per sample); efforts on ``effort_topic`` when given."""
    names = names or ds.joints
    with Writer(path, version=9, storage_plugin=storage) as w:
        conn = w.add_connection(topic, JS, typestore=STORE)
        econn = w.add_connection(effort_topic, JS, typestore=STORE) if effort_topic else None
        for other, msgtype in extra:
            w.add_connection(other, msgtype, typestore=STORE)
        for k, tk in enumerate(ds.t):
            ns = T0_NS + int(round(tk * 1e9))
            vel = ds.dq[k] if ds.dq is not None else ()
            eff = ds.tau[k] if (ds.tau is not None and econn is None) else ()
            w.write(conn, ns + 1000, STORE.serialize_cdr(_msg(ns, names, ds.q[k], vel, eff), JS))
            if econn is not None:
                w.write(econn, ns + 2000, STORE.serialize_cdr(_msg(ns, names, effort=ds.tau[k]), JS))
    return path


@pytest.fixture(scope="module")
def twin():
    from pinid.excitation.trajectory import FourierTrajectory
    from pinid.simulation.twin import simulate

    model = load("exo_leg")
    traj = FourierTrajectory(
        ["hip", "knee"],
        0.2 * np.pi,
        [0.61, -0.87],
        [[0.25, 0.1, 0.05], [0.25, -0.1, 0.05]],
        [[0.1, 0.05, 0.02], [-0.1, 0.05, 0.02]],
    )
    ds, _ = simulate(model, traj, seconds=10, seed=1, sample_rate=500.0, record_velocity=True)
    return model, ds


def _same(a: Dataset, b: Dataset) -> None:
    assert a.joints == b.joints
    np.testing.assert_allclose(b.t, a.t, rtol=0, atol=1e-9)
    for k in ("q", "dq", "tau"):
        np.testing.assert_array_equal(getattr(b, k), getattr(a, k))


@pytest.mark.parametrize("storage", [StoragePlugin.MCAP, StoragePlugin.SQLITE3], ids=["mcap", "sqlite3"])
def test_bag_folder_reads_as_the_dataset_and_identifies_the_same(tmp_path, twin, storage):
    model, ds = twin
    bag = write_bag(tmp_path / "run", ds, storage=storage)
    back = read_recording(bag, model=model)  # no mapping spec: joint names are the URDF's
    _same(ds, back)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = identify(Study(model, ds), methods=["ols"])
        b = identify(Study(model, bag), methods=["ols"])
    np.testing.assert_allclose(b["ols"].base, a["ols"].base, rtol=1e-9, atol=1e-12)


def test_plain_mcap_file_with_a_mapping_spec(tmp_path, twin):
    """The .mcap inside a bag folder on its own; a spec renames joints, flips a sign, reads efforts from
    their own topic and uses the receive clock."""
    model, ds = twin
    bag = write_bag(
        tmp_path / "run",
        ds,
        names=["left_hip_joint", "left_knee_joint"],
        effort_topic="/efforts",
        extra=[("/chatter", "std_msgs/msg/String")],
    )
    mcap = next(bag.glob("*.mcap"))
    spec = {
        "ros": {"topic": "/joint_states", "effort_topic": "/efforts", "time": "receive"},
        "joints": {
            "hip": {"q": "q_left_hip_joint", "tau": "tau_left_hip_joint"},
            "knee": {
                "q": "q_left_knee_joint",
                "dq": "dq_left_knee_joint",
                "tau": {"column": "tau_left_knee_joint", "sign": -1},
            },
        },
    }
    with pytest.raises(SpecError, match="dq given for joints"):
        read_recording(mcap, mapping=spec, model=model)
    spec["joints"]["hip"]["dq"] = "dq_left_hip_joint"
    back = read_recording(mcap, mapping=spec, model=model)
    # efforts are received 1 µs after the positions: the first position sample, before any effort, is
    # dropped, and the efforts are interpolated onto the positions' receive times
    np.testing.assert_allclose(back.t, ds.t[1:], atol=1e-9)
    np.testing.assert_array_equal(back.q, ds.q[1:])
    np.testing.assert_allclose(back.tau[:, 0], ds.tau[1:, 0], rtol=0, atol=2e-3 * np.ptp(ds.tau[:, 0]))
    np.testing.assert_allclose(back.tau[:, 1], -ds.tau[1:, 1], rtol=0, atol=2e-3 * np.ptp(ds.tau[:, 1]))


def test_bag_errors_are_one_line(tmp_path, twin):
    model, ds = twin
    short = Dataset(ds.t[:50], ds.q[:50], ds.joints, tau=ds.tau[:50])
    bag = write_bag(tmp_path / "run", short, names=["hip", "ankle"], extra=[("/chatter", "std_msgs/msg/String")])
    with pytest.raises(DataError, match=r"joint 'knee' is not in topic /joint_states \(its joints: hip, ankle\)"):
        read_recording(bag, mapping={"ros": {}, "joints": {"hip": {"q": "q_hip"}, "knee": {"q": "q_knee"}}})
    with pytest.raises(SpecError, match=r"no topic /js; its topics: /chatter \(std_msgs/msg/String\), /joint_states"):
        read_recording(bag, mapping={"ros": {"topic": "/js"}, "joints": {"hip": {"q": "q_hip"}}})
    with pytest.raises(SpecError, match="topic /chatter has message type std_msgs/msg/String, expected sensor_msgs"):
        read_recording(bag, mapping={"ros": {"topic": "/chatter"}, "joints": {"hip": {"q": "q_hip"}}})
    with pytest.raises(DataError, match="message 0 of /joint_states has no velocity"):
        read_recording(bag, mapping={"ros": {}, "joints": {"hip": {"q": "q_hip", "dq": "dq_hip"}}})
    with pytest.raises(SpecError, match=r"\[ros\] time = 'wall'"):
        read_recording(bag, mapping={"ros": {"time": "wall"}, "joints": {"hip": {"q": "q_hip"}}})
    with pytest.raises(SpecError, match=r"\[ros\] ignore_topics = '/ft_raw', expected a list of topic names"):
        read_recording(bag, mapping={"ros": {"ignore_topics": "/ft_raw"}, "joints": {"hip": {"q": "q_hip"}}})
    with pytest.raises(SpecError, match=r"unknown key 'topics' in \[ros\]"):
        read_recording(bag, mapping={"ros": {"topics": "/a"}, "joints": {"hip": {"q": "q_hip"}}})
    empty = tmp_path / "empty"
    with Writer(empty, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        w.add_connection("/joint_states", JS, typestore=STORE)
    with pytest.raises(DataError, match="topic /joint_states has no messages"):
        read_recording(empty)
    # through the CLI: one line, status 2
    proc = run_cli("identify", "--urdf", "exo_leg", "--data", str(bag), "--methods", "ols", "-o", str(tmp_path / "o"))
    assert_clean_error(proc, "ankle")
