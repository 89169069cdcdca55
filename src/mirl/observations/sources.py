"""One entry point for L's observations from any file: a grid CSV (``t,robot,row,col,heading``),
a pose CSV (``t,robot,x,y,yaw`` or ``qz,qw``), a ROS 1 ``.bag``, a ROS 2 bag directory or an
``.mcap`` file. Pose data is discretised onto the scenario's map (:mod:`mirl.discretise`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mirl.observations._csv import csv_header
from mirl.observations.bags import SUPPORTED_TYPES, BagError, bag_topics, is_bag, read_bag
from mirl.observations.discretise import Discretised, discretise
from mirl.observations.poses import PoseError, PoseTracks, read_pose_csv
from mirl.observations.tf import TF_TYPE
from mirl.observations.trajectories import Trajectories, TrajectoryError, read_csv
from mirl.world.scenario import Scenario

__all__ = ["LoadedObservations", "load_observations", "observation_kind", "ROBOT_DATA_KINDS"]

# kinds of observation file that hold robot data (measured poses), not a simulation of a scenario
ROBOT_DATA_KINDS = ("pose-csv", "bag")


@dataclass(frozen=True)
class LoadedObservations:
    trajectories: Trajectories
    kind: str  # "grid-csv", "pose-csv" or "bag"
    discretised: Discretised | None = None  # for pose data: the counts and the visible cells

    def visible_states(self, scenario: Scenario) -> np.ndarray | None:
        """(S,) visible states for the learner, or None for the scenario's degree."""
        return None if self.discretised is None else self.discretised.visible_states(scenario)


def _topic_map(topics: Mapping[str, str] | Sequence[tuple[str, str]] | None) -> dict[str, str]:
    """topic -> robot; a topic given twice is refused (a dict would keep the last silently)."""
    pairs = list(topics.items()) if isinstance(topics, Mapping) else list(topics or [])
    out: dict[str, str] = {}
    for topic, robot in pairs:
        if topic in out:
            raise ValueError(
                f"`topics`: {topic} given twice ({topic}={out[topic]} and {topic}={robot})"
            )
        out[topic] = robot
    return out


def observation_kind(path: str | Path) -> str:
    """``bag``, ``grid-csv`` or ``pose-csv`` (by the header), or a one-line error."""
    path = Path(path)
    if is_bag(path):
        return "bag"
    if path.is_dir():
        raise PoseError(f"{path}: a directory but not a ROS 2 bag (no metadata.yaml)")
    header = csv_header(path, TrajectoryError)
    if "row" in header and "col" in header:
        return "grid-csv"
    if "x" in header and "y" in header:
        return "pose-csv"
    raise TrajectoryError(
        f"{path}: line 1: not a grid CSV (t,robot,row,col,heading) nor a pose CSV (t,robot,x,y,yaw)"
    )


def load_observations(
    path: str | Path,
    scenario: Scenario,
    *,
    topics: Mapping[str, str] | Sequence[tuple[str, str]] | None = None,
    step_seconds: float | None = None,
    start_time: float | None = None,
    tolerance: float | None = None,
    drop_off_map: bool = False,
    visible: str | np.ndarray | None = None,
    observability: float | None = None,
    same_frames: Mapping[str, str] | None = None,
) -> LoadedObservations:
    """Read observations of ``scenario``'s robots from ``path`` (kind told by the file).

    ``topics``: for a bag, topic → robot (required); for a pose CSV, an optional renaming of
    the file's robot names. The discretisation options apply to pose data only; giving one
    for a grid CSV is an error rather than silently ignored. ``visible`` (pose data): the cells
    L could see, handed to the learner — by default those of ``observability`` (default: the
    scenario's degree) along the map's visibility order; ``"observed"``: every cell a robot was
    observed on; or a (rows, cols) bool mask. ``same_frames`` (bags): frames that coincide
    (frame -> frame), so that topics recorded in both may be mixed (:func:`~mirl.observations.
    bags.read_bag`).
    """
    path = Path(path)
    topics = _topic_map(topics)
    kind = observation_kind(path)
    names = scenario.robot_names
    if kind == "grid-csv":
        given = [
            flag
            for flag, value in (
                ("`topics`", topics or None),
                ("`step_seconds`", step_seconds),
                ("`start_time`", start_time),
                ("`tolerance`", tolerance),
                ("`drop_off_map`", drop_off_map or None),
                ("`visible`", visible),
                ("`same_frames`", same_frames or None),
            )
            if value is not None
        ]
        if given:
            raise ValueError(f"{path}: {given[0]} applies to pose data; this is a grid CSV")
        return LoadedObservations(read_csv(path, scenario.domain, names), kind)
    if kind == "bag":
        if not topics:
            found = bag_topics(path)
            poses = [f"{t} ({m})" for t, (m, _) in found.items() if m in SUPPORTED_TYPES]
            poses += [f"{t}:CHILD_FRAME ({m})" for t, (m, _) in found.items() if m == TF_TYPE]
            raise BagError(
                f"{path}: say which topic is which robot with `topics` TOPIC=ROBOT "
                f"(pose topics in the bag: {', '.join(poses) or 'none'})"
            )
        tracks = read_bag(path, topics, robot_names=names, same_frames=same_frames)
    else:
        if same_frames:
            raise ValueError(f"{path}: `same_frames` applies to bags; a pose CSV has no frames")
        tracks = read_pose_csv(path)
        if topics:
            tracks = _rename(tracks, topics)
    if visible is None:
        degree = scenario.observability if observability is None else observability
        visible = scenario.map.visible_mask(degree)
    d = discretise(
        tracks,
        scenario,
        step_seconds=2.0 if step_seconds is None else step_seconds,
        start_time=start_time,
        tolerance=tolerance,
        drop_off_map=drop_off_map,
        visible=visible,
    )
    return LoadedObservations(d.trajectories, kind, d)


def _rename(tracks: PoseTracks, mapping: Mapping[str, str]) -> PoseTracks:
    for old in mapping:
        if old not in tracks.robot_names:
            raise PoseError(f"{tracks.source}: `topics` {old}=...: no robot '{old}' in the file")
    names = [mapping.get(n, n) for n in tracks.robot_names]
    merged: list[str] = list(dict.fromkeys(names))
    lut = np.array([merged.index(n) for n in names], dtype=np.int64)
    return PoseTracks(
        tuple(merged), tracks.t, lut[tracks.robot], tracks.x, tracks.y, tracks.yaw, tracks.source
    ).sorted()
