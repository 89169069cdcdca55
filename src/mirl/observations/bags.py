"""Pose tracks from ROS bags through ``rosbags`` (pure Python, no ROS install).

Reads ROS 1 ``.bag`` files, ROS 2 bag directories (sqlite3 or MCAP storage) and bare ``.mcap``
files. Supported messages: ``geometry_msgs/msg/PoseStamped``,
``geometry_msgs/msg/PoseWithCovarianceStamped`` (AMCL) and ``nav_msgs/msg/Odometry``. Time is
``header.stamp``; x, y and yaw come from the pose (the map frame is assumed: the topics the user
names must be in the map frame, as AMCL output is).

Decoding: ``rosbags`` hands over each message's raw bytes; instead of building one Python
object per message (``typestore.deserialize_cdr``/``deserialize_ros1``, ~10 µs each), the
messages of a topic are stacked into a byte matrix per message length and the stamp and pose
fields are read at their offsets with numpy (the offsets depend only on the lengths of the
``frame_id``/``child_frame_id`` strings, read vectorised too). The first and last message of
every topic are also deserialised by ``rosbags`` and compared, and anything the fast path does
not know (big-endian or XCDR2 CDR) goes through ``rosbags`` message by message
(``decode="rosbags"`` forces that path; the benchmark measures both).

Every problem — a file that is not a bag, a truncated bag, a missing topic, a topic of an
unsupported type, a NaN pose, a header stamp going backwards within a topic, a topic mapped to
a robot the scenario does not have — is a one-line :class:`BagError` naming the file and topic.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from mirl.observations.poses import (
    MAX_QUATERNION,
    PoseError,
    PoseTracks,
    far_quaternion,
    yaw_from_quaternion,
)
from mirl.observations.tf import TF_STATIC, TF_TYPE, Transforms, compose_track, split_tf_topic

__all__ = ["BagError", "read_bag", "write_mcap", "bag_topics", "SUPPORTED_TYPES", "is_bag"]

# message type -> number of strings between the header and the pose (Odometry: child_frame_id)
SUPPORTED_TYPES = {
    "geometry_msgs/msg/PoseStamped": 0,
    "geometry_msgs/msg/PoseWithCovarianceStamped": 0,
    "nav_msgs/msg/Odometry": 1,
}
_POSE_BYTES = 56  # position x, y, z and orientation x, y, z, w: 7 float64


class BagError(PoseError):
    """A bag that cannot be used; the one-line message names the file and topic."""


def is_bag(path: str | Path) -> bool:
    """Whether ``path`` looks like a bag: ``.bag``, ``.mcap``, ``.db3`` or a ROS 2 bag directory.

    Parameters
    ----------
    path : str or Path
        A file or directory.

    Returns
    -------
    bool
        True for those suffixes or a directory holding ``metadata.yaml``.
    """
    path = Path(path)
    return path.suffix.lower() in (".bag", ".mcap", ".db3") or (path / "metadata.yaml").exists()


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or exc.__class__.__name__
    return text if len(text) < 200 else text[:197] + "..."


def _typestore(ros2: bool):
    from rosbags.typesys import Stores, get_typestore

    return get_typestore(Stores.ROS2_HUMBLE if ros2 else Stores.ROS1_NOETIC)


def _reader(path: Path):
    from rosbags.highlevel import AnyReader

    if not path.exists():
        raise BagError(f"{path}: no such file or directory")
    # rosbags tells a file's storage by its suffix as written; a ROS 2 bag directory by its
    # metadata.yaml, whatever its name (a dot in it is no suffix: run.RobotA)
    if not path.is_dir() and path.suffix != path.suffix.lower():
        raise BagError(
            f"{path}: rosbags reads bags by their lower-case suffix; rename it to "
            f"{path.with_suffix(path.suffix.lower()).name}"
        )
    ros2 = path.suffix.lower() != ".bag"
    try:
        return AnyReader([path], default_typestore=_typestore(ros2)), ros2
    except Exception as exc:  # rosbags raises many kinds on a file that is not a bag
        raise BagError(f"{path}: cannot read bag ({_one_line(exc)})") from None


def bag_topics(path: str | Path) -> dict[str, tuple[str, int]]:
    """The topics of a bag.

    Parameters
    ----------
    path : str or Path
        The bag.

    Returns
    -------
    dict of str to (str, int)
        topic -> (message type, message count).

    Raises
    ------
    BagError
        A file that is not a readable bag.
    """
    path = Path(path)
    reader, _ = _reader(path)
    try:
        with reader:
            return {k: (v.msgtype or "?", v.msgcount) for k, v in reader.topics.items()}
    except BagError:
        raise
    except Exception as exc:
        raise BagError(f"{path}: cannot read bag ({_one_line(exc)})") from None


def read_bag(
    path: str | Path,
    topics: Mapping[str, str],
    *,
    robot_names: Sequence[str] | None = None,
    decode: str = "fast",
    same_frames: Mapping[str, str] | None = None,
    map_frame: str = "map",
) -> PoseTracks:
    """Poses of the ``topics`` of a bag, sorted by (robot, t).

    A topic ``/tf:CHILD`` (a ``tf2_msgs/msg/TFMessage`` topic and a child frame) reads robot
    CHILD's pose from the bag's transforms (:mod:`mirl.observations.tf`, ``/tf_static``
    included), composed up to ``map_frame``. Pose topics must all be in one frame: topics in
    different frames are refused unless ``same_frames`` says how they relate. Several topics may
    feed one robot.

    Parameters
    ----------
    path : str or Path
        A ROS 1 ``.bag``, a ROS 2 bag directory or an ``.mcap`` file.
    topics : mapping of str to str
        Each topic's robot (topic -> robot name).
    robot_names : sequence of str, optional
        The scenario's robots, checked first: a topic mapped to a robot not in it is an error
        naming the topic, and the result is indexed into it.
    decode : {"fast", "rosbags"}, default "fast"
        ``"fast"`` (vectorised, checked against rosbags) or ``"rosbags"`` (one ``deserialize``
        call per message).
    same_frames : mapping of str to str, optional
        Frames that coincide (frame -> the frame it coincides with); each first frame must be
        one a topic read is in or a transform read names.
    map_frame : str, default "map"
        The frame TF chains are composed up to.

    Returns
    -------
    PoseTracks
        The poses, one row per message (TF: per stamp of the robot's own transform).

    Raises
    ------
    BagError
        Any problem, in one line naming the file and topic.
    ValueError
        An unknown ``decode``.
    """
    path = Path(path)
    if decode not in ("fast", "rosbags"):
        raise ValueError(f"decode must be 'fast' or 'rosbags', got {decode!r}")
    if not topics:
        raise BagError(f"{path}: no topics given (map at least one topic to a robot)")
    if robot_names is not None:
        for topic, robot in topics.items():
            if robot not in robot_names:
                known = ", ".join(robot_names)
                raise BagError(
                    f"{path}: topic {topic}: robot '{robot}' is not in the scenario ({known})"
                )
    same = dict(same_frames or {})
    tf_robots = {t: r for t, r in topics.items() if split_tf_topic(t) is not None}
    topics = {t: r for t, r in topics.items() if t not in tf_robots}
    reader, ros2 = _reader(path)
    raws: dict[str, list[bytes]] = {topic: [] for topic in topics}
    try:
        with reader:
            available = reader.topics
            parts, tf_frames = (
                _tf_parts(path, reader, tf_robots, same, map_frame) if tf_robots else ([], set())
            )
            for topic in topics:
                if topic not in available:
                    have = ", ".join(sorted(available)) or "none"
                    raise BagError(f"{path}: topic {topic}: not in the bag (topics: {have})")
                msgtype = available[topic].msgtype
                if msgtype not in SUPPORTED_TYPES:
                    raise BagError(
                        f"{path}: topic {topic}: unsupported message type {msgtype} "
                        f"(supported: {', '.join(SUPPORTED_TYPES)})"
                    )
            conns = [c for c in reader.connections if c.topic in raws]
            # no connections would read every message (rosbags' default): none are wanted
            for conn, _, raw in reader.messages(connections=conns) if conns else ():
                raws[conn.topic].append(raw)
            topic_frames: dict[str, str] = {}
            for topic, robot in topics.items():
                msgtype = available[topic].msgtype
                cols, frames = _decode(reader, raws[topic], msgtype, ros2, decode)
                if len(frames) > 1:  # poses in two frames cannot be placed on one map
                    raise BagError(
                        f"{path}: topic {topic}: messages in {len(frames)} frames "
                        f"({', '.join(sorted(frames)[:4])}); its poses must all be in the map frame"
                    )
                part = _check(path, topic, robot, cols)
                if frames:
                    frame = next(iter(frames)).lstrip("/")
                    topic_frames[topic] = frame
                    part = replace(part, frames={robot: frame})
                parts.append(part)
            _check_one_frame(path, topic_frames, same, map_frame if tf_robots else None)
            _check_same_frames_used(path, same, set(topic_frames.values()) | tf_frames)
    except BagError:
        raise
    except Exception as exc:  # truncated or corrupt bag: rosbags, struct, zstd, lz4 errors
        raise BagError(f"{path}: cannot read bag ({_one_line(exc)})") from None
    tracks = PoseTracks.concat(parts, source=str(path))
    if robot_names is not None:
        tracks = tracks.with_robot_names(robot_names)
    return tracks


def _check_one_frame(
    path: Path, topic_frames: Mapping[str, str], same: Mapping[str, str], tf_frame: str | None
) -> None:
    """Pose topics (and TF robots, placed in ``tf_frame``) must share one frame, up to the
    frames ``same`` declares to coincide: a pose in ``odom`` and one in ``map`` are not on
    one grid unless the user says so."""
    canon = {t: same.get(f, f) for t, f in topic_frames.items()}
    if tf_frame is not None:
        canon["(transforms)"] = same.get(tf_frame, tf_frame)
    if len(set(canon.values())) <= 1:
        return
    listed = ", ".join(f"{t} in '{topic_frames.get(t, tf_frame)}'" for t in canon)
    a, b = sorted(set(canon.values()))[:2]
    raise BagError(
        f"{path}: poses in different frames ({listed}); mirl places them on one map only if "
        f"you say how the frames relate: `same_frames` {a}={b} if they coincide"
    )


def _check_same_frames_used(path: Path, same: Mapping[str, str], frames: set[str]) -> None:
    """Refuse a ``same_frames`` pair whose first frame nothing read is in (no pose topic, no
    transform): it would change nothing, and is most likely a misspelt frame or another bag's."""
    for frame, other in same.items():
        if frame not in frames:
            read = ", ".join(f"'{f}'" for f in sorted(frames)) or "none"
            raise BagError(
                f"{path}: `same_frames` {frame}={other}: no pose topic read is in frame "
                f"'{frame}' and no transform read names it (frames read: {read}), so it would "
                "change nothing"
            )


def _tf_parts(
    path: Path, reader, tf_robots, same, map_frame: str
) -> tuple[list[PoseTracks], set[str]]:
    """Each TF robot's track, composed through the bag's transforms (:mod:`mirl.observations.
    tf`); a robot frame the transforms never mention is an error naming the frames they do.
    Also every frame the transforms name."""
    available = reader.topics
    tf_topics = {split_tf_topic(t)[0] for t in tf_robots}  # type: ignore[index]
    for topic in sorted(tf_topics):
        if topic not in available:
            have = ", ".join(sorted(available)) or "none"
            raise BagError(f"{path}: topic {topic}: not in the bag (topics: {have})")
        if available[topic].msgtype != TF_TYPE:
            raise BagError(
                f"{path}: topic {topic}: a child frame (TOPIC:FRAME) needs a {TF_TYPE} topic, "
                f"not {available[topic].msgtype}"
            )
    if TF_STATIC in available and available[TF_STATIC].msgtype == TF_TYPE:
        tf_topics.add(TF_STATIC)
    conns = [c for c in reader.connections if c.topic in tf_topics]  # never empty: checked
    transforms = Transforms.from_messages(
        (conn.topic, reader.deserialize(raw, conn.msgtype))
        for conn, _, raw in reader.messages(connections=conns)
    )
    parts = []
    for topic, robot in tf_robots.items():
        _, child = split_tf_topic(topic)  # type: ignore[misc]
        if child not in transforms.parent:
            frames = ", ".join(sorted(transforms.parent)[:8]) or "none"
            raise BagError(
                f"{path}: topic {topic}: no transform into frame '{child}' "
                f"(child frames in the bag: {frames})"
            )
        try:
            t, x, y, yaw, unplaced = compose_track(transforms, child, map_frame, same)
        except ValueError as exc:
            raise BagError(f"{path}: topic {topic}: {exc}") from None
        back = np.flatnonzero(np.diff(t) < 0)
        if back.size:  # sorted per link: only equal stamps remain, which binning handles
            raise BagError(f"{path}: topic {topic}: transform stamps go backwards")
        parts.append(
            PoseTracks(
                (robot,),
                t,
                np.zeros(len(t), dtype=np.int64),
                x,
                y,
                yaw,
                str(path),
                {robot: f"{map_frame} via {topic.split(':')[0]} from {child}"},
                {robot: unplaced},
            )  # fmt: skip
        )
    return parts, set(transforms.parent) | set(transforms.parent.values())


def _check(path: Path, topic: str, robot: str, cols: np.ndarray) -> PoseTracks:
    """(n, 8) columns t, x, y, z, qx, qy, qz, qw of one topic -> tracks; NaN, a zero quaternion
    (an orientation never filled in) or time going backwards is an error naming the message."""
    t, x, y = cols[:, 0], cols[:, 1], cols[:, 2]
    bad = ~np.isfinite(cols).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise BagError(f"{path}: topic {topic}: message {i} (stamp {t[i]:.9f} s): NaN pose")
    far = far_quaternion(cols[:, 4:8])
    if far.any():
        i = int(np.argmax(far))
        raise BagError(
            f"{path}: topic {topic}: message {i} (stamp {t[i]:.9f} s): orientation component "
            f"beyond ±{MAX_QUATERNION:g} (a quaternion's components lie in [-1, 1])"
        )
    zero = (cols[:, 4:8] ** 2).sum(axis=1) < 1e-12
    if zero.any():
        i = int(np.argmax(zero))
        raise BagError(
            f"{path}: topic {topic}: message {i} (stamp {t[i]:.9f} s): orientation is the zero "
            "quaternion (not filled in?)"
        )
    if np.count_nonzero(t == 0.0) > 1:
        raise BagError(
            f"{path}: topic {topic}: {np.count_nonzero(t == 0.0)} messages have header stamp 0 "
            "(stamps not filled in?)"
        )
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        i = int(back[0]) + 1
        raise BagError(
            f"{path}: topic {topic}: header stamp goes backwards at message {i} "
            f"({t[i]:.9f} s after {t[i - 1]:.9f} s)"
        )
    yaw = yaw_from_quaternion(cols[:, 4], cols[:, 5], cols[:, 6], cols[:, 7])
    n = len(t)
    return PoseTracks((robot,), t, np.zeros(n, dtype=np.int64), x, y, yaw, str(path))


# ---- decoding ------------------------------------------------------------------------------
def _decode(
    reader, raws: list[bytes], msgtype: str, ros2: bool, decode: str
) -> tuple[np.ndarray, set[str]]:
    """(n, 8) float64: stamp seconds, position xyz, orientation xyzw; and the header frame_ids
    the messages name."""
    if not raws:
        return np.zeros((0, 8)), set()
    fast = _decode_fast(raws, SUPPORTED_TYPES[msgtype], ros2) if decode == "fast" else None
    cols, frames = fast if fast is not None else (None, set())
    if cols is not None:
        # the fast path must agree with rosbags on the first and last message
        for i in {0, len(raws) - 1}:
            ref, frame = _decode_one(reader, raws[i], msgtype)
            if not np.array_equal(ref, cols[i], equal_nan=True) or frame not in frames:
                cols = None
                break
    if cols is None:
        decoded = [_decode_one(reader, raw, msgtype) for raw in raws]
        cols = np.array([values for values, _ in decoded], dtype=np.float64)
        frames = {frame for _, frame in decoded}
    return cols, frames


def _decode_one(reader, raw: bytes, msgtype: str) -> tuple[np.ndarray, str]:
    msg = reader.deserialize(raw, msgtype)
    pose = msg.pose.pose if msgtype != "geometry_msgs/msg/PoseStamped" else msg.pose
    stamp = msg.header.stamp
    sec = stamp.sec if hasattr(stamp, "sec") else stamp.secs  # ROS 2 / ROS 1 field names
    nsec = stamp.nanosec if hasattr(stamp, "nanosec") else stamp.nsecs
    p, q = pose.position, pose.orientation
    values = [sec + nsec * 1e-9, p.x, p.y, p.z, q.x, q.y, q.z, q.w]
    return np.array(values, dtype=np.float64), str(msg.header.frame_id)


def _u32(buf: np.ndarray, rows: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """Little-endian uint32 at per-row byte offsets of a (n, L) uint8 matrix."""
    idx = offset[:, None] + np.arange(4)
    return np.ascontiguousarray(buf[rows[:, None], idx]).view("<u4")[:, 0].astype(np.int64)


def _decode_fast(
    raws: list[bytes], n_strings: int, ros2: bool
) -> tuple[np.ndarray, set[str]] | None:
    """Vectorised decoding of stamp and pose; None if the layout is not one it knows.

    ROS 2 (classic little-endian CDR): 4-byte encapsulation header, then stamp sec (int32),
    nanosec (uint32), frame_id (uint32 length incl. NUL, bytes), [child_frame_id aligned to 4],
    then the pose's 7 float64 aligned to 8 (alignment counted after the encapsulation header).
    ROS 1: seq, secs, nsecs (uint32), frame_id (uint32 length, bytes), [child_frame_id], pose
    packed without alignment.
    """
    lengths = np.fromiter(map(len, raws), dtype=np.int64, count=len(raws))
    out = np.empty((len(raws), 8), dtype=np.float64)
    frames: set[str] = set()
    base = 4 if ros2 else 0
    for length in np.unique(lengths):
        which = np.flatnonzero(lengths == length)
        if length < base + 16:
            return None
        blob = b"".join(raws[i] for i in which) if len(which) < len(raws) else b"".join(raws)
        buf = np.frombuffer(blob, dtype=np.uint8).reshape(len(which), int(length))
        rows = np.arange(len(which))
        if ros2 and not (np.all(buf[:, 0] == 0) and np.all(buf[:, 1] == 1)):
            return None  # big-endian or XCDR2: leave it to rosbags
        end = 16 + _u32(buf, rows, np.full(len(which), 12, dtype=np.int64))  # after frame_id
        if np.any(end > length):
            return None
        frames |= _frame_ids(buf, end - 16)
        if ros2:
            sec = np.ascontiguousarray(buf[:, 4:8]).view("<i4")[:, 0].astype(np.int64)
            nsec = np.ascontiguousarray(buf[:, 8:12]).view("<u4")[:, 0].astype(np.int64)
            for _ in range(n_strings):
                start = base + (((end - base) + 3) // 4) * 4
                if np.any(start + 4 > length):
                    return None
                end = start + 4 + _u32(buf, rows, start)
            pose_at = base + ((end - base + 7) // 8) * 8
        else:
            sec = np.ascontiguousarray(buf[:, 4:8]).view("<u4")[:, 0].astype(np.int64)
            nsec = np.ascontiguousarray(buf[:, 8:12]).view("<u4")[:, 0].astype(np.int64)
            for _ in range(n_strings):
                if np.any(end + 4 > length):
                    return None
                end = end + 4 + _u32(buf, rows, end)
            pose_at = end
        if np.any(pose_at + _POSE_BYTES > length):
            return None
        if np.all(pose_at == pose_at[0]):
            a = int(pose_at[0])
            pose = np.ascontiguousarray(buf[:, a : a + _POSE_BYTES]).view("<f8")
        else:
            idx = pose_at[:, None] + np.arange(_POSE_BYTES)
            pose = np.ascontiguousarray(buf[rows[:, None], idx]).view("<f8")
        out[which, 0] = sec + nsec * 1e-9
        out[which, 1:] = pose
    return out, frames


def _frame_ids(buf: np.ndarray, sizes: np.ndarray) -> set[str]:
    """The distinct header frame_ids of (n, L) messages whose frame_id (``sizes`` bytes with
    its NUL) starts at byte 16 (ROS 1 and little-endian ROS 2 CDR alike)."""
    found: set[bytes] = set()
    for size in np.unique(sizes):
        names = buf[sizes == size, 16 : 16 + int(size)]
        other = (names != names[0]).any(axis=1)  # usually none: np.unique's sort only if any
        found.add(bytes(names[0]))
        if other.any():
            found |= {bytes(n) for n in np.unique(names[other], axis=0)}
    return {n.rstrip(b"\0").decode("utf-8", "replace") for n in found}


# ---- writing -------------------------------------------------------------------------------
def _pose_stamped_cdr(t: np.ndarray, x, y, yaw, frame_id: str) -> np.ndarray:
    """(n, L) uint8: CDR little-endian ``geometry_msgs/msg/PoseStamped`` messages."""
    fid = frame_id.encode() + b"\0"
    end = 4 + 12 + len(fid)
    pose_at = 4 + ((end - 4 + 7) // 8) * 8
    length = pose_at + _POSE_BYTES
    n = len(t)
    buf = np.zeros((n, length), dtype=np.uint8)
    buf[:, 1] = 1  # CDR_LE encapsulation
    sec, nsec = _split_stamp(t)
    buf[:, 4:8] = sec.astype("<i4").view(np.uint8).reshape(n, 4)
    buf[:, 8:12] = nsec.astype("<u4").view(np.uint8).reshape(n, 4)
    buf[:, 12:16] = np.frombuffer(np.uint32(len(fid)).astype("<u4").tobytes(), dtype=np.uint8)
    buf[:, 16 : 16 + len(fid)] = np.frombuffer(fid, dtype=np.uint8)
    pose = np.zeros((n, 7), dtype="<f8")
    pose[:, 0], pose[:, 1] = x, y
    pose[:, 5], pose[:, 6] = np.sin(yaw / 2.0), np.cos(yaw / 2.0)
    buf[:, pose_at:] = pose.view(np.uint8).reshape(n, _POSE_BYTES)
    return buf


def _split_stamp(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Seconds -> (sec, nanosec), nanosec in [0, 1e9)."""
    ns = np.round(np.asarray(t, dtype=np.float64) * 1e9).astype(np.int64)
    return ns // 1_000_000_000, ns % 1_000_000_000


def write_mcap(
    tracks: PoseTracks,
    path: str | Path,
    topic: str = "/{robot}/pose",
    frame_id: str = "map",
) -> None:
    """Write a ROS 2 bag with MCAP storage, one ``PoseStamped`` topic per robot.

    Log time = header stamp.

    Parameters
    ----------
    tracks : PoseTracks
        The poses; stamps must not be negative, poses must be finite.
    path : str or Path
        Ending in ``.mcap``: a bare MCAP file (readable by ``ros2 bag``, Foxglove and
        :func:`read_bag`); anything else: a ROS 2 bag directory with ``metadata.yaml``. It must
        not exist.
    topic : str, default "/{robot}/pose"
        The topic of each robot, ``{robot}`` replaced by its name.
    frame_id : str, default "map"
        The messages' ``header.frame_id``.

    Raises
    ------
    BagError
        Negative stamps, non-finite poses, a path that exists already, or one ending in
        ``.mcap`` in capitals (which :func:`read_bag` would refuse).
    """
    from rosbags.rosbag2 import StoragePlugin, Writer

    path = Path(path)
    if len(tracks) and np.min(tracks.t) < 0:
        raise BagError(f"{path}: cannot write negative stamps (t min {np.min(tracks.t)})")
    if not np.all(np.isfinite(np.column_stack([tracks.t, tracks.x, tracks.y, tracks.yaw]))):
        raise BagError(f"{path}: cannot write NaN or infinite poses")
    if path.exists():
        raise BagError(f"{path}: exists already, not overwriting")
    if path.suffix.lower() == ".mcap" and path.suffix != ".mcap":  # read_bag would refuse it
        raise BagError(
            f"{path}: an MCAP file is read by its lower-case suffix; name it "
            f"{path.with_suffix('.mcap').name}"
        )
    bare = path.suffix == ".mcap"
    tmp = Path(tempfile.mkdtemp(prefix=".mirl-", dir=path.parent)) if bare else None
    target = path if tmp is None else tmp / path.stem
    typestore = _typestore(True)
    msgtype = "geometry_msgs/msg/PoseStamped"
    try:
        with Writer(target, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
            for i, name in enumerate(tracks.robot_names):
                conn = writer.add_connection(topic.format(robot=name), msgtype, typestore=typestore)
                sel = np.flatnonzero(tracks.robot == i)
                sel = sel[np.argsort(tracks.t[sel], kind="stable")]
                buf = _pose_stamped_cdr(
                    tracks.t[sel], tracks.x[sel], tracks.y[sel], tracks.yaw[sel], frame_id
                )
                sec, nsec = _split_stamp(tracks.t[sel])
                stamps = (sec * 1_000_000_000 + nsec).tolist()
                write = writer.write
                for ts, row in zip(stamps, buf, strict=True):
                    write(conn, ts, row.data)
        if bare:
            inner = sorted(target.glob("*.mcap"))
            shutil.move(str(inner[0]), str(path))
    except BagError:
        raise
    except Exception as exc:
        raise BagError(f"{path}: cannot write bag ({_one_line(exc)})") from None
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
