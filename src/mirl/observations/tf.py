"""Robot poses from a bag's transforms (``/tf``, ``/tf_static``: ``tf2_msgs/msg/TFMessage``),
for bags that record no pose topic (docs/design.md, "Frames and TF").

A robot is a *child frame* (``/tf:base_footprint``); its pose in the map frame is the
composition of the transforms from the map frame down to it, as tf2 would look them up:

* the times are the stamps of the lowest moving link of the chain — the transforms into the
  robot's frame (odom → base_footprint, published with every odometry update), or, for a
  frame mounted statically on the robot (base_link under base_footprint), into its mount:
  the robot's own motion;
* every other link of the chain (map → odom from a localiser, static mounts) takes its latest
  transform at or before that stamp, no older than :data:`TF_TOLERANCE` seconds; a static
  transform (``/tf_static``) holds at any time. A stamp where a link has none is dropped and
  counted (``no_transform``), never extrapolated;
* the composition is planar (x, y and yaw; roll and pitch are dropped), as the grid is.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from mirl.observations.poses import yaw_from_quaternion

__all__ = ["TF_TYPE", "TF_TOLERANCE", "Transforms", "split_tf_topic", "compose_track"]

TF_TYPE = "tf2_msgs/msg/TFMessage"
TF_STATIC = "/tf_static"
# the age of the latest transform of a link a pose may use: a localiser publishes map → odom at
# 1–10 Hz, so a second covers several of its updates without reaching back to another place
TF_TOLERANCE = 1.0


def split_tf_topic(topic: str) -> tuple[str, str] | None:
    """``/tf:base_footprint`` -> ("/tf", "base_footprint").

    ROS topic names have no colon, so the colon can only mean a child frame.

    Parameters
    ----------
    topic : str
        A topic as the user wrote it.

    Returns
    -------
    (str, str) or None
        The TF topic and the child frame; None for a plain topic.
    """
    if ":" not in topic:
        return None
    name, _, child = topic.partition(":")
    return name.strip(), child.strip().lstrip("/")


@dataclass
class _Link:
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    static: bool


class Transforms:
    """Every transform of a bag's TF topics, per (parent, child) link, sorted by stamp.

    Parameters
    ----------
    rows : list of tuple
        (parent, child, stamp, x, y, yaw, static) of every transform; frames' leading slashes
        are dropped.
    """

    def __init__(self, rows: list[tuple[str, str, float, float, float, float, bool]]) -> None:
        by_link: dict[tuple[str, str], list[tuple[tuple[float, ...], bool]]] = {}
        for parent, child, t, x, y, yaw, is_static in rows:
            key = (parent.lstrip("/"), child.lstrip("/"))
            by_link.setdefault(key, []).append(((t, x, y, yaw), is_static))
        self.links: dict[tuple[str, str], _Link] = {}
        self.parent: dict[str, str] = {}
        for (parent, child), values in by_link.items():
            a = np.array([v for v, _ in values], dtype=float)
            order = np.argsort(a[:, 0], kind="stable")
            a = a[order]
            static = any(st for _, st in values)
            self.links[(parent, child)] = _Link(a[:, 0], a[:, 1], a[:, 2], a[:, 3], static)
            self.parent.setdefault(child, parent)  # a frame has one parent in a TF tree

    @classmethod
    def from_messages(cls, messages) -> Transforms:
        """From (topic, deserialised TFMessage) pairs.

        Parameters
        ----------
        messages : iterable of (str, object)
            The topic (``/tf`` or ``/tf_static``) and the message.

        Returns
        -------
        Transforms
            Their transforms.
        """
        rows = []
        for topic, msg in messages:
            for tr in msg.transforms:
                stamp = tr.header.stamp
                q = tr.transform.rotation
                yaw = float(yaw_from_quaternion(q.x, q.y, q.z, q.w))
                p = tr.transform.translation
                rows.append(
                    (
                        str(tr.header.frame_id),
                        str(tr.child_frame_id),
                        stamp.sec + stamp.nanosec * 1e-9,
                        float(p.x),
                        float(p.y),
                        yaw,
                        topic == TF_STATIC,
                    )
                )
        return cls(rows)

    def chain(self, child: str, map_frame: str) -> list[tuple[str, str]]:
        """The links from ``map_frame`` down to ``child``, top first.

        Parameters
        ----------
        child : str
            A robot's frame.
        map_frame : str
            The frame to reach.

        Returns
        -------
        list of (str, str)
            The (parent, child) links.

        Raises
        ------
        ValueError
            The map frame is not above the child (the message names the frames reached).
        """
        links: list[tuple[str, str]] = []
        frame, seen = child, {child}
        while frame != map_frame:
            parent = self.parent.get(frame)
            if parent is None or parent in seen:
                # the frames walked, top first as TF writes a link (parent -> child)
                path = " -> ".join([*(p for p, _ in reversed(links)), child])
                raise ValueError(
                    f"frame '{child}' is not below the map frame '{map_frame}' in the bag's "
                    f"transforms (it reaches {path or child}); record the localiser's "
                    f"{map_frame} -> ... transform, or say that a frame is the map frame "
                    "(`same_frames`)"
                )
            links.append((parent, frame))
            seen.add(parent)
            frame = parent
        return links[::-1]


def compose_track(
    transforms: Transforms,
    child: str,
    map_frame: str = "map",
    same_frames: Mapping[str, str] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """The pose of frame ``child`` in ``map_frame`` at the stamps of its own transform.

    Parameters
    ----------
    transforms : Transforms
        The bag's transforms.
    child : str
        The robot's frame.
    map_frame : str, default "map"
        The frame the poses are in.
    same_frames : mapping of str to str, optional
        Frames that coincide with the map frame (frame -> map frame): the chain may stop at one
        of them.

    Returns
    -------
    t : ndarray of shape (n,)
        Stamps, seconds.
    x : ndarray of shape (n,)
        Metres in the map frame.
    y : ndarray of shape (n,)
        Metres in the map frame.
    yaw : ndarray of shape (n,)
        Radians.
    dropped : int
        The stamps dropped for a link with no transform within :data:`TF_TOLERANCE` (module doc).

    Raises
    ------
    ValueError
        The child is the map frame, not below it, or never moves.
    """
    stops = {map_frame, *(f for f, m in (same_frames or {}).items() if m == map_frame)}
    frame, links = child, list[tuple[str, str]]()
    while frame not in stops:
        parent = transforms.parent.get(frame)
        if parent is None or (parent, frame) in links:
            links = transforms.chain(child, map_frame)  # raises, naming what it reached
            break
        links.append((parent, frame))
        frame = parent
    links = links[::-1]
    if not links:
        raise ValueError(f"frame '{child}' is the map frame itself, not a robot")
    moving = [transforms.links[k] for k in links if not transforms.links[k].static]
    if not moving:
        raise ValueError(f"every transform above frame '{child}' is static: it does not move")
    own = moving[-1]
    t = own.t
    x, y, yaw = np.zeros(len(t)), np.zeros(len(t)), np.zeros(len(t))
    ok = np.ones(len(t), dtype=bool)
    for link in links:  # compose from the map frame down: pose ∘ link
        L = transforms.links[link]
        if L is own:
            lx, ly, lyaw = L.x, L.y, L.yaw
        else:
            i = np.searchsorted(L.t, t, side="right") - 1  # latest at or before the stamp
            have = i >= 0
            if not L.static:
                have &= t - L.t[np.maximum(i, 0)] <= TF_TOLERANCE
            i = np.maximum(i, 0)
            if L.static:  # a static transform holds at any time: its latest one
                i = np.full(len(t), len(L.t) - 1)
                have = np.ones(len(t), dtype=bool)
            ok &= have
            lx, ly, lyaw = L.x[i], L.y[i], L.yaw[i]
        c, s = np.cos(yaw), np.sin(yaw)
        x, y, yaw = x + c * lx - s * ly, y + s * lx + c * ly, yaw + lyaw
    yaw = np.mod(yaw + np.pi, 2 * np.pi) - np.pi
    return t[ok], x[ok], y[ok], yaw[ok], int((~ok).sum())
