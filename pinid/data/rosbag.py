"""ROS 2 recordings: rosbag2 folders (sqlite3 or MCAP storage) and plain ``.mcap`` / ``.db3`` files.

``sensor_msgs/msg/JointState`` messages become the columns of pinid's dataset format, by joint name:
``t``, ``q_<joint>`` (position [rad or m]), ``dq_<joint>`` (velocity) and ``tau_<joint>`` (effort [N·m or
N]), so a bag whose joint names are the URDF's is read with no mapping spec at all.  A mapping spec
chooses the topics and the clock, and renames, scales or flips joints as for any file::

    time = "t"
    [ros]
    topic = "/joint_states"          # default: /joint_states, else the bag's only JointState topic
    effort_topic = "/joint_efforts"  # optional: efforts from another JointState topic (interpolated)
    time = "header"                  # "header" (message stamps, default) or "receive" (bag time)
    [joints.hip]
    q = "q_left_hip_joint"
    tau = { column = "tau_left_hip_joint", sign = -1 }

Floating base (docs/floating-base.md): every ``sensor_msgs/msg/Imu`` topic also gives the columns
``imu_<frame>_qx … _qw`` (orientation), ``_wx, _wy, _wz`` (angular velocity) and ``_ax, _ay, _az`` (linear
acceleration, the specific force an accelerometer measures), and every ``geometry_msgs/msg/WrenchStamped``
topic ``wrench_<frame>_fx … _tz``, ``<frame>`` being the messages' ``header.frame_id`` (a URDF link), linearly
interpolated onto the JointState samples (which they must cover).  Two topics that would give the same
columns (same message type and frame, such as a F/T driver's compensated and raw wrenches) are refused, not
merged: ``[ros] ignore_topics = ["/ft_raw"]`` leaves the unwanted ones out.

``t`` is in seconds from the first message of ``topic``.  When the messages of a topic name different
joints (several publishers on one topic), the samples are the messages that hold every joint asked for.
Read with ``rosbags`` (pure Python, no ROS installation needed).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pinid.data.registry import Reader, Table, register_reader
from pinid.errors import DataError, PinidError, SpecError

JOINT_STATE = "sensor_msgs/msg/JointState"
IMU = "sensor_msgs/msg/Imu"
WRENCH = "geometry_msgs/msg/WrenchStamped"
#: column suffixes of the side messages and how to read them from a message
SIDE = {
    IMU: ("imu_", ("qx", "qy", "qz", "qw", "wx", "wy", "wz", "ax", "ay", "az")),
    WRENCH: ("wrench_", ("fx", "fy", "fz", "tx", "ty", "tz")),
}


def _side_values(msg, msgtype: str) -> list[float]:
    if msgtype == IMU:
        o, w, a = msg.orientation, msg.angular_velocity, msg.linear_acceleration
        return [o.x, o.y, o.z, o.w, w.x, w.y, w.z, a.x, a.y, a.z]
    f, t = msg.wrench.force, msg.wrench.torque
    return [f.x, f.y, f.z, t.x, t.y, t.z]


def _read_side(
    file: Path, clock: str, ignore: tuple[str, ...] = ()
) -> dict[str, tuple[np.ndarray, np.ndarray, list[str]]]:
    """Every Imu and WrenchStamped topic of a bag but those in ``ignore``: ``{column prefix "imu_<frame>_":
    (stamps [ns], (N, k) values, the topics that gave them)}``; more than one topic under a prefix is an
    ambiguous source, refused where its columns are read (:func:`_side_samples`)."""
    from rosbags.rosbag2 import Reader as BagReader
    from rosbags.typesys import Stores, get_typestore

    bag = BagReader(file)
    bag.open()
    try:
        unknown = [t for t in ignore if t not in {c.topic for c in bag.connections}]
        if unknown:
            raise SpecError(f"{file}: [ros] ignore_topics names {unknown[0]!r}, which is not a topic of the bag")
        conns = [c for c in bag.connections if c.msgtype in SIDE and c.topic not in ignore]
        if not conns:
            return {}
        store = get_typestore(Stores.LATEST)
        raw: dict[str, tuple[list, list, dict]] = {}
        for conn, received, data in bag.messages(connections=conns):
            msg = store.deserialize_cdr(data, conn.msgtype)
            frame = msg.header.frame_id or conn.topic.strip("/").replace("/", "_")
            stamp = msg.header.stamp
            ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec) if clock == "header" else int(received)
            stamps, values, topics = raw.setdefault(f"{SIDE[conn.msgtype][0]}{frame}_", ([], [], {}))
            topics[conn.topic] = None
            stamps.append(ns)
            values.append(_side_values(msg, conn.msgtype))
    finally:
        bag.close()
    out = {}
    for prefix, (stamps, values, topics) in raw.items():
        st = np.asarray(stamps, dtype=np.int64)
        order = np.argsort(st, kind="stable")
        out[prefix] = (st[order], np.asarray(values, dtype=float)[order], list(topics))
    return out


def _side_columns(prefix: str) -> list[str]:
    return [prefix + c for c in _suffixes(prefix)]


DEFAULT_TOPIC = "/joint_states"
#: dataset-format prefix → JointState field
FIELDS = {"q_": "position", "dq_": "velocity", "tau_": "effort"}
_OPTION_KEYS = {"topic", "effort_topic", "time", "ignore_topics"}


def _is_bag_folder(path: Path) -> bool:
    """A rosbag2 folder: a directory with a ``metadata.yaml``."""
    return path.is_dir() and (path / "metadata.yaml").is_file()


def options(source, origin: str) -> dict:
    """The ``[ros]`` table of a mapping spec's source, checked: ``topic``, ``effort_topic``, ``time``,
    ``ignore_topics`` (Imu / WrenchStamped topics to leave out)."""
    raw = getattr(source, "ros", None) or {}
    unknown = sorted(set(raw) - _OPTION_KEYS)
    if unknown:
        raise SpecError(
            f"{origin}: unknown key '{unknown[0]}' in [ros]; expected some of {', '.join(sorted(_OPTION_KEYS))}"
        )
    for key in ("topic", "effort_topic"):
        if key in raw and not (isinstance(raw[key], str) and raw[key]):
            raise SpecError(f'{origin}: [ros] {key} = {raw[key]!r}, expected a topic name such as "/joint_states"')
    clock = raw.get("time", "header")
    if clock not in ("header", "receive"):
        raise SpecError(f'{origin}: [ros] time = {clock!r}, expected "header" (message stamps) or "receive" (bag time)')
    ignore = raw.get("ignore_topics", [])
    if not (isinstance(ignore, list) and all(isinstance(x, str) and x for x in ignore)):
        raise SpecError(
            f'{origin}: [ros] ignore_topics = {ignore!r}, expected a list of topic names such as ["/ft_raw"]'
        )
    return {"topic": raw.get("topic"), "effort_topic": raw.get("effort_topic"), "time": clock, "ignore": tuple(ignore)}


class _Topic:
    """The JointState messages of one topic: time stamps [ns] and, per message, names and arrays."""

    def __init__(self, stamps: np.ndarray, names: list[tuple[str, ...]], fields: dict[str, list[np.ndarray]]):
        self.stamps, self.names, self.fields = stamps, names, fields

    def joints(self) -> list[str]:
        """Every joint name the topic carries, in order of first appearance."""
        seen: dict[str, None] = {}
        for ns in dict.fromkeys(self.names):
            seen.update(dict.fromkeys(ns))
        return list(seen)

    def has(self, field: str) -> bool:
        """Whether any message fills ``field`` (JointState leaves unmeasured fields empty)."""
        return any(len(a) for a in self.fields[field])

    def samples(self, joints: list[str], fields: list[str], file: Path, topic: str):
        """``(stamps [ns], {(field, joint): values})`` over the messages holding every joint in ``joints``."""
        missing = [j for j in joints if j not in self.joints()]
        if missing:
            raise DataError(
                f"{file}: joint '{missing[0]}' is not in topic {topic} (its joints: {', '.join(self.joints())})"
            )
        index_of: dict[tuple[str, ...], list[int] | None] = {}
        keep = []
        for k, ns in enumerate(self.names):
            if ns not in index_of:
                pos = {n: i for i, n in enumerate(ns)}
                index_of[ns] = [pos[j] for j in joints] if all(j in pos for j in joints) else None
            if index_of[ns] is not None:
                keep.append(k)
        if not keep:
            raise DataError(
                f"{file}: no message of {topic} holds all of {', '.join(joints)} together; "
                "expected one JointState message per sample with every joint"
            )
        out = {}
        for field in fields:
            cols = np.full((len(keep), len(joints)), np.nan)
            for r, k in enumerate(keep):
                a = self.fields[field][k]
                if len(a) == 0:
                    raise DataError(
                        f"{file}: message {k} of {topic} has no {field} (an empty array), "
                        f"expected {field} in every message"
                    )
                if len(a) != len(self.names[k]):
                    raise DataError(
                        f"{file}: message {k} of {topic} has {len(self.names[k])} joint names and {len(a)} "
                        f"{field} values, expected one {field} per name"
                    )
                cols[r] = a[index_of[self.names[k]]]
            for i, j in enumerate(joints):
                out[(field, j)] = cols[:, i]
        return self.stamps[keep], out


def _read_topics(file: Path, topics: list[str | None], clock: str) -> dict[str, _Topic]:
    """Read the JointState messages of ``topics`` (None: /joint_states or the only JointState topic)."""
    try:
        from rosbags.rosbag2 import Reader as BagReader
        from rosbags.typesys import Stores, get_typestore
    except ModuleNotFoundError:  # pragma: no cover - a declared dependency
        raise DataError(f"{file}: reading ROS 2 bags needs the 'rosbags' package (pip install rosbags)") from None
    if not file.exists():
        raise DataError(
            f"{file}: not found, expected a ROS 2 bag (a folder with metadata.yaml, or a .mcap or .db3 file)"
        )
    try:
        bag = BagReader(file)
        bag.open()
    except Exception as exc:  # rosbags raises its own error types, and OSError/KeyError on damaged files
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(f"{file}: not a readable ROS 2 bag ({msg})") from None
    try:
        kinds = {c.topic: c.msgtype for c in bag.connections}
        listing = ", ".join(f"{t} ({m})" for t, m in sorted(kinds.items())) or "none"
        chosen: list[str] = []
        for t in topics:
            if t is None:
                states = sorted(x for x, m in kinds.items() if m == JOINT_STATE)
                if DEFAULT_TOPIC in kinds or len(states) != 1:
                    t = DEFAULT_TOPIC
                else:
                    t = states[0]
            if t not in kinds:
                raise SpecError(f"{file}: no topic {t}; its topics: {listing} (choose one with [ros] topic = ...)")
            if kinds[t] != JOINT_STATE:
                raise SpecError(f"{file}: topic {t} has message type {kinds[t]}, expected {JOINT_STATE}")
            chosen.append(t)
        store = get_typestore(Stores.LATEST)
        raw: dict[str, tuple[list, list, dict]] = {t: ([], [], {f: [] for f in FIELDS.values()}) for t in chosen}
        conns = [c for c in bag.connections if c.topic in raw]
        for conn, received, data in bag.messages(connections=conns):
            msg = store.deserialize_cdr(data, conn.msgtype)
            stamps, names, fields = raw[conn.topic]
            stamp = msg.header.stamp
            stamps.append(int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec) if clock == "header" else int(received))
            names.append(tuple(msg.name))
            for f in fields:
                fields[f].append(np.asarray(getattr(msg, f), dtype=float))
    except PinidError:
        raise
    except Exception as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(f"{file}: cannot read the ROS 2 bag ({msg})") from None
    finally:
        bag.close()
    out = {}
    for t, (stamps, names, fields) in raw.items():
        if not stamps:
            raise DataError(f"{file}: topic {t} has no messages, expected {JOINT_STATE} samples")
        st = np.asarray(stamps, dtype=np.int64)
        if clock == "header" and not st.any():
            raise DataError(f'{file}: every header stamp of {t} is zero; use [ros] time = "receive" (bag time)')
        order = np.argsort(st, kind="stable")
        out[t] = _Topic(st[order], [names[k] for k in order], {f: [v[k] for k in order] for f, v in fields.items()})
    return out


def _columns(file: Path) -> list[str]:
    """The dataset-format columns of the default JointState topic: t, q_<joint>, dq_<joint>, tau_<joint>."""
    topic = next(iter(_read_topics(file, [None], "header").values()))
    names = ["t"]
    for prefix, field in FIELDS.items():
        if prefix == "q_" or topic.has(field):
            names += [prefix + j for j in topic.joints()]
    for prefix in _read_side(file, "header"):
        names += _side_columns(prefix)
    return names


def _read(file: Path, source, wanted, origin: str) -> Table:
    """The ``wanted`` columns (``t``, ``q_<joint>``, ``dq_<joint>``, ``tau_<joint>``) of a bag."""
    opts = options(source, origin)
    effort_apart = opts["effort_topic"] is not None
    topics = _read_topics(file, [opts["topic"]] + ([opts["effort_topic"]] if effort_apart else []), opts["time"])
    names = list(topics)
    main = topics[names[0]]
    effort = topics[names[-1]]
    asked: dict[str, list[str]] = {}  # field -> joints
    side_cols = [c for c, _i, _w in wanted if isinstance(c, str) and c.startswith(("imu_", "wrench_"))]
    for col, _index, where in wanted:
        if col == "t" or col in side_cols:
            continue
        prefix = next((p for p in FIELDS if isinstance(col, str) and col.startswith(p) and len(col) > len(p)), None)
        if prefix is None:
            raise SpecError(
                f"{origin}: {where} column {col!r} is not a column of a ROS 2 bag; expected t, "
                "q_<joint>, dq_<joint> or tau_<joint> (JointState position, velocity, effort)"
            )
        asked.setdefault(FIELDS[prefix], []).append(col[len(prefix) :])
    inline = {f: js for f, js in asked.items() if not (effort_apart and f == "effort")}
    joints = list(dict.fromkeys(j for js in inline.values() for j in js)) or main.joints()[:1]
    stamps, values = main.samples(joints, list(inline), file, names[0])
    t0 = stamps[0]
    if effort_apart and "effort" in asked:
        e_stamps, e_values = effort.samples(asked["effort"], ["effort"], file, names[-1])
        te, tm = (e_stamps - t0) * 1e-9, (stamps - t0) * 1e-9
        if te[-1] < tm[0] or te[0] > tm[-1]:
            raise DataError(
                f"{file}: {names[-1]} [{te[0]:g}, {te[-1]:g}] s does not overlap {names[0]} "
                f"[{tm[0]:g}, {tm[-1]:g}] s, expected efforts of the same run"
            )
        inside = (tm >= te[0]) & (tm <= te[-1])
        stamps, tm = stamps[inside], tm[inside]
        values = {k: v[inside] for k, v in values.items()}
        for j in asked["effort"]:
            values[("effort", j)] = np.interp(tm, te, e_values[("effort", j)])
    side = _side_samples(file, side_cols, stamps, opts["time"], origin, opts["ignore"]) if side_cols else {}
    tab = Table(
        file, ["t"] + [p + j for p, f in FIELDS.items() for j in asked.get(f, [])] + side_cols, {}, len(stamps), None
    )
    for col, index, _where in wanted:
        if col == "t":
            tab.data[(col, index)] = (stamps - t0) * 1e-9
        elif col in side:
            tab.data[(col, index)] = side[col]
        else:
            prefix = next(p for p in FIELDS if col.startswith(p))
            tab.data[(col, index)] = values[(FIELDS[prefix], col[len(prefix) :])]
    return tab


def _side_samples(
    file: Path, cols: list[str], stamps: np.ndarray, clock: str, origin: str, ignore: tuple[str, ...] = ()
) -> dict[str, np.ndarray]:
    """The Imu / WrenchStamped columns ``cols`` interpolated onto the JointState ``stamps`` [ns]; SpecError when
    two topics give the same columns (same message type and ``header.frame_id``): their messages would be
    merged into one series."""
    side = _read_side(file, clock, ignore)
    out = {}
    for col in cols:
        prefix = next((p for p in side if col.startswith(p) and col[len(p) :] in _suffixes(p)), None)
        if prefix is None:
            have = ", ".join(c for p in side for c in _side_columns(p)[:1]) or "none"
            raise SpecError(
                f"{origin}: column {col!r} is not in {file.name}: no Imu or WrenchStamped messages with that "
                f"header.frame_id (first columns of its Imu/WrenchStamped topics: {have})"
            )
        st, values, topics = side[prefix]
        if len(topics) > 1:
            raise SpecError(
                f"{file}: topics {' and '.join(topics)} both give the {prefix}* columns (same message type and "
                f"header.frame_id), so their messages would be merged; choose one with a mapping spec: [ros] "
                f'ignore_topics = ["{topics[-1]}"]'
            )
        if st[0] > stamps[0] or st[-1] < stamps[-1]:
            raise DataError(
                f"{file}: the {prefix[:-1]} messages [{(st[0] - stamps[0]) * 1e-9:g}, {(st[-1] - stamps[0]) * 1e-9:g}] s "
                f"do not cover the joint states [0, {(stamps[-1] - stamps[0]) * 1e-9:g}] s; expected the same run"
            )
        k = _suffixes(prefix).index(col[len(prefix) :])
        out[col] = np.interp(stamps.astype(float), st.astype(float), values[:, k])
    return out


def _suffixes(prefix: str) -> tuple[str, ...]:
    return next(sfx for pre, sfx in SIDE.values() if prefix.startswith(pre))


def example(path: Path, names: list[str], data: np.ndarray) -> Path:
    """A rosbag2 folder (MCAP storage) at ``path``: one ``sensor_msgs/msg/JointState`` on ``/joint_states`` per
    row of ``data``, whose dataset-format columns ``names`` (t, q_<joint>, dq_<joint>, tau_<joint>) give
    the stamps, positions, velocities and efforts (for the reader contract suite; pinid writes no bags)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.LATEST)
    types = store.types
    col = {n: data[:, i] for i, n in enumerate(names)}
    joints = [n[2:] for n in names if n.startswith("q_")]
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/joint_states", JOINT_STATE, typestore=store)
        for k, tk in enumerate(col["t"]):
            ns = 1_700_000_000_000_000_000 + int(round(tk * 1e9))
            stamp = types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            fields = {
                f: np.array([col[p + j][k] for j in joints]) if all(p + j in col for j in joints) else np.zeros(0)
                for p, f in FIELDS.items()
            }
            msg = types[JOINT_STATE](
                header=types["std_msgs/msg/Header"](stamp=stamp, frame_id=""), name=joints, **fields
            )
            w.write(conn, ns, store.serialize_cdr(msg, JOINT_STATE))
    return path


register_reader(
    Reader(
        "ros2bag",
        _read,
        suffixes=(".mcap", ".db3"),
        columns=_columns,
        match=_is_bag_folder,
        folder=True,
        example=example,
    )
)
