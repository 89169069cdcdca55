"""Hand-built ROS 1 and ROS 2 bags for the reader tests (rosbags' own writers and serialisers)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

POSE_TYPES = {
    "stamped": "geometry_msgs/msg/PoseStamped",
    "amcl": "geometry_msgs/msg/PoseWithCovarianceStamped",
    "odom": "nav_msgs/msg/Odometry",
}
_NUMPY = {
    "bool": np.bool_,
    "int8": np.int8,
    "uint8": np.uint8,
    "int16": np.int16,
    "uint16": np.uint16,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
    "float32": np.float32,
    "float64": np.float64,
}


def typestore(ros2: bool):
    """rosbags' type store of the ROS release, with tf2_msgs/msg/TFMessage (which neither
    store ships) registered, for TF-only bags."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE if ros2 else Stores.ROS1_NOETIC)
    if "tf2_msgs/msg/TFMessage" not in ts.types:
        ts.register(
            get_types_from_msg(
                "geometry_msgs/TransformStamped[] transforms", "tf2_msgs/msg/TFMessage"
            )
        )
    return ts


def default_message(ts, typename: str):
    """A message of ``typename`` with every field zero / empty."""
    _, fields = ts.fielddefs[typename]
    values = {}
    for name, (kind, spec) in fields:
        kind = int(kind)
        if kind == 1:  # base
            base = spec[0]
            values[name] = "" if base == "string" else (False if base == "bool" else 0)
            if base in ("float32", "float64"):
                values[name] = 0.0
        elif kind == 2:  # nested message
            values[name] = default_message(ts, spec)
        elif kind == 3:  # fixed array
            (sub_kind, sub), count = spec
            values[name] = np.zeros(count, dtype=_NUMPY[sub[0]])
        else:  # sequence
            (sub_kind, sub), _ = spec
            if int(sub_kind) == 1 and sub[0] in _NUMPY:
                values[name] = np.zeros(0, dtype=_NUMPY[sub[0]])
            else:
                values[name] = []
    return ts.types[typename](**values)


def pose_message(ts, kind: str, t: float, x: float, y: float, yaw: float, frame="map"):
    msgtype = POSE_TYPES[kind]
    msg = default_message(ts, msgtype)
    sec = math.floor(t)
    msg.header.stamp.sec = int(sec)
    msg.header.stamp.nanosec = int(round((t - sec) * 1e9))
    msg.header.frame_id = frame
    pose = msg.pose if kind == "stamped" else msg.pose.pose
    pose.position.x, pose.position.y, pose.position.z = x, y, 0.25
    pose.orientation.z, pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    if kind == "odom":
        msg.child_frame_id = "base_link"
    return msgtype, msg


def string_message(ts, text: str):
    msg = default_message(ts, "std_msgs/msg/String")
    msg.data = text
    return "std_msgs/msg/String", msg


def write_bag(path: Path, records, *, fmt: str) -> Path:
    """Write ``records`` — (topic, log time s, (msgtype, message)) — in the given order.

    ``fmt``: ``ros1`` (a .bag file), ``sqlite3`` or ``mcap`` (a ROS 2 bag directory).
    """
    ros2 = fmt != "ros1"
    ts = typestore(ros2)
    if ros2:
        from rosbags.rosbag2 import StoragePlugin, Writer

        plugin = StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3
        writer = Writer(path, version=9, storage_plugin=plugin)
    else:
        from rosbags.rosbag1 import Writer

        writer = Writer(path)
    conns = {}
    with writer:
        for topic, log_time, (msgtype, msg) in records:
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=ts)
            data = ts.serialize_cdr(msg, msgtype) if ros2 else ts.serialize_ros1(msg, msgtype)
            writer.write(conns[topic], int(round(log_time * 1e9)), data)
    return path
