"""One entry point for L's observations from any file, and the table of input formats.

Each format is a row of :data:`FORMATS`: how its files are recognised, whether they hold robot
data (measured poses, discretised onto the scenario's map by :mod:`mirl.observations.discretise`)
or grid observations, and its reader. Today: a grid CSV (``t,robot,row,col,heading``), a pose
CSV (``t,robot,x,y,yaw`` or ``qz,qw``), and a bag (a ROS 1 ``.bag``, a ROS 2 bag directory or an
``.mcap`` file). Adding a format is its reader and a row.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mirl._registry import Registry
from mirl.observations._csv import csv_header, is_text
from mirl.observations.bags import SUPPORTED_TYPES, BagError, bag_topics, is_bag, read_bag
from mirl.observations.discretise import Discretised, discretise
from mirl.observations.poses import PoseError, PoseTracks, read_pose_csv
from mirl.observations.tf import TF_TYPE
from mirl.observations.trajectories import Trajectories, TrajectoryError, read_csv
from mirl.world.scenario import Scenario

__all__ = [
    "FORMATS",
    "InputFormat",
    "LoadedObservations",
    "load_observations",
    "observation_kind",
    "ROBOT_DATA_KINDS",
]


@dataclass(frozen=True)
class LoadedObservations:
    """Observations read from a file, with what their format tells about them.

    Parameters
    ----------
    trajectories : Trajectories
        The observed grid states.
    kind : str
        The name of its format in :data:`FORMATS`: ``grid-csv``, ``pose-csv`` or ``bag``.
    discretised : Discretised, optional
        For pose data: the discretisation's counts and the cells L could see.
    left_out : mapping of str to int, default {}
        Robot data read with ``topics``: each robot of a pose CSV, or each pose topic of a bag,
        that no topic names, and its poses (messages), which were not read.
    """

    trajectories: Trajectories
    kind: str  # the name of its format in FORMATS: "grid-csv", "pose-csv" or "bag"
    discretised: Discretised | None = None  # for pose data: the counts and the visible cells
    left_out: Mapping[str, int] = field(default_factory=dict)  # robot of the file -> its poses

    def visible_states(self, scenario: Scenario) -> np.ndarray | None:
        """The states L could see, for the learner.

        Parameters
        ----------
        scenario : Scenario
            The scenario the observations are of.

        Returns
        -------
        ndarray of bool, shape (S,), or None
            The visible states of pose data; None for grid data (the scenario's degree holds).
        """
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


@dataclass(frozen=True)
class _ReadOptions:
    topics: dict[str, str]
    robot_names: tuple[str, ...]
    same_frames: Mapping[str, str] | None
    left_out: dict[str, int] = field(default_factory=dict)  # the reader's: robot -> poses


@dataclass(frozen=True)
class InputFormat:
    """One row of the table of input formats.

    Parameters
    ----------
    name : str
        The format's name (``LoadedObservations.kind``).
    description : str
        What its files hold, for messages.
    recognises : callable
        ``recognises(path, header)`` -> bool, with ``header`` the CSV header's column names
        (empty for a directory or a file that is not text).
    robot_data : bool
        Whether it holds measured poses (robot data, discretised onto the map), not a
        simulation's grid observations.
    read : callable
        ``read(path, scenario, options)`` -> :class:`~mirl.observations.poses.PoseTracks`
        (robot data) or :class:`~mirl.observations.trajectories.Trajectories`.
    """

    name: str
    description: str
    recognises: Callable[[Path, tuple[str, ...]], bool]
    robot_data: bool
    read: Callable[[Path, Scenario, _ReadOptions], PoseTracks | Trajectories]


def _read_bag(path: Path, scenario: Scenario, options: _ReadOptions) -> PoseTracks:
    if not options.topics:
        found = bag_topics(path)
        poses = [f"{t} ({m})" for t, (m, _) in found.items() if m in SUPPORTED_TYPES]
        poses += [f"{t}:CHILD_FRAME ({m})" for t, (m, _) in found.items() if m == TF_TYPE]
        raise BagError(
            f"{path}: say which topic is which robot with `topics` TOPIC=ROBOT "
            f"(pose topics in the bag: {', '.join(poses) or 'none'})"
        )
    tracks = read_bag(
        path, options.topics, robot_names=options.robot_names, same_frames=options.same_frames
    )
    # said, not dropped silently, as a pose CSV's robots are: a pose topic no `topics` names
    # may be a robot the user forgot (topics of other types are cameras, maps, logs)
    named = {topic.split(":", 1)[0] for topic in options.topics}
    for topic, (msgtype, count) in bag_topics(path).items():
        if msgtype in SUPPORTED_TYPES and topic not in named and count:
            options.left_out[topic] = int(count)
    return tracks


def _read_pose_csv(path: Path, scenario: Scenario, options: _ReadOptions) -> PoseTracks:
    if options.same_frames:
        raise ValueError(f"{path}: `same_frames` applies to bags; a pose CSV has no frames")
    tracks = read_pose_csv(path)
    if not options.topics:
        return tracks
    for name, robot in options.topics.items():  # as a bag's topic: named, not the file's robot
        if robot not in options.robot_names:
            known = ", ".join(options.robot_names)
            raise PoseError(
                f"{path}: `topics` {name}={robot}: robot '{robot}' is not in the scenario ({known})"
            )
    tracks, left_out = _select_robots(tracks, options.topics)
    options.left_out.update(left_out)
    return tracks


def _read_grid_csv(path: Path, scenario: Scenario, options: _ReadOptions) -> Trajectories:
    return read_csv(path, scenario.domain, options.robot_names)


FORMATS: Registry[InputFormat] = Registry("input format", (
    InputFormat(
        "bag", "a ROS 1 .bag, a ROS 2 bag directory or an .mcap file",
        lambda path, header: is_bag(path), robot_data=True, read=_read_bag,
    ),
    InputFormat(
        "grid-csv", "a grid CSV (t,robot,row,col,heading)",
        lambda path, header: "row" in header and "col" in header, robot_data=False,
        read=_read_grid_csv,
    ),
    InputFormat(
        "pose-csv", "a pose CSV (t,robot,x,y,yaw)",
        lambda path, header: "x" in header and "y" in header, robot_data=True,
        read=_read_pose_csv,
    ),
))  # fmt: skip
"""Every input format by name, tried in this order."""

ROBOT_DATA_KINDS = tuple(f.name for f in FORMATS.values() if f.robot_data)
"""The formats that hold robot data (measured poses), not a simulation of a scenario."""


def input_format(path: str | Path) -> InputFormat:
    """The format of ``path`` (told by the file), or a one-line error."""
    path = Path(path)
    where = f"{path}"  # a text file's refusal names its first line, the header it read
    if is_bag(path):
        header: tuple[str, ...] = ()
    elif path.is_dir():
        raise PoseError(f"{path}: a directory but not a ROS 2 bag (no metadata.yaml)")
    elif not is_text(path):  # an image, say: no format below, which the message lists
        header = ()
    else:
        header = tuple(csv_header(path, TrajectoryError))
        where = f"{path}: line 1"
    for fmt in FORMATS.values():
        if fmt.recognises(path, header):
            return fmt
    known = "; ".join(f.description for f in FORMATS.values())
    raise TrajectoryError(f"{where}: not a file of observations mirl reads ({known})")


def observation_kind(path: str | Path) -> str:
    """The name of ``path``'s input format (:func:`input_format`).

    Parameters
    ----------
    path : str or Path
        An observations file or bag.

    Returns
    -------
    str
        A name in :data:`FORMATS`.

    Raises
    ------
    PoseError
        A file no format recognises (the message lists the formats).
    """
    return input_format(path).name


def load_observations(
    path: str | Path,
    scenario: Scenario,
    *,
    topics: Mapping[str, str] | Sequence[tuple[str, str]] | None = None,
    step_seconds: float | str | None = None,
    start_time: float | None = None,
    tolerance: float | None = None,
    drop_off_map: bool = False,
    visible: str | np.ndarray | None = None,
    observability: float | None = None,
    same_frames: Mapping[str, str] | None = None,
) -> LoadedObservations:
    """Read observations of ``scenario``'s robots from ``path`` (kind told by the file).

    The discretisation options apply to pose data only; giving one for a grid CSV is an error
    rather than silently ignored.

    Parameters
    ----------
    path : str or Path
        A grid CSV, a pose CSV or a bag.
    scenario : Scenario
        The scenario whose robots and map the observations are of.
    topics : mapping of str to str, or sequence of (str, str), optional
        For a bag, topic → robot (required). For a pose CSV, the file's robot → the scenario
        robot it is: only the robots named are read (:attr:`LoadedObservations.left_out` counts
        the others' poses); without it every robot of the file is read.

        .. versionchanged:: 0.2.0
           On a pose CSV it selects the robots it names, as on a bag (it renamed them and read
           the others too).
    step_seconds : float or "auto", optional
        Pose data: seconds a decision step, or ``"auto"`` (the default, None): the robots' own
        pace (:func:`~mirl.observations.discretise.auto_step_seconds`).

        .. versionchanged:: 0.2.0
           Defaults to ``"auto"`` (it was 2 s).
    start_time : float, optional
        Pose data: the time of step 0; the first pose's if None.
    tolerance : float, optional
        Pose data: how far (seconds) from a step's time a pose may be and still count for it;
        half a step if None, and at most half a step.
    drop_off_map : bool, default False
        Pose data: drop poses off the hallway (counted) instead of refusing the file.
    visible : str or ndarray of bool, optional
        Pose data: the cells L could see, handed to the learner — by default those of
        ``observability`` along the map's visibility order; ``"observed"``: every cell a robot
        was observed on; or a (rows, cols) bool mask.
    observability : float, optional
        Pose data: the degree ``visible`` defaults to; the scenario's by default (refused with
        ``visible``, which it would not change).
    same_frames : mapping of str to str, optional
        Bags: frames that coincide (frame -> frame), so that topics recorded in both may be
        mixed (:func:`~mirl.observations.bags.read_bag`).

    Returns
    -------
    LoadedObservations
        The observations, their format's name and, for pose data, the discretisation.

    Raises
    ------
    TrajectoryError, PoseError or BagError
        A problem with the file, in one line naming it.
    ValueError
        An option that does not apply to the file's format.
    """
    path = Path(path)
    fmt = input_format(path)
    options = _ReadOptions(_topic_map(topics), scenario.robot_names, same_frames)
    if not fmt.robot_data:
        given = [
            flag
            for flag, value in (
                ("`topics`", options.topics or None),
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
            raise ValueError(f"{path}: {given[0]} applies to pose data; this is {fmt.description}")
        grid = fmt.read(path, scenario, options)
        assert isinstance(grid, Trajectories)
        return LoadedObservations(grid, fmt.name)
    if visible is not None and observability is not None:  # one would be ignored
        raise ValueError(
            "`observability` sets the cells L could see, and `visible` gives them: give one of "
            "them"
        )
    tracks = fmt.read(path, scenario, options)
    assert isinstance(tracks, PoseTracks)
    if visible is None:
        degree = scenario.observability if observability is None else observability
        visible = scenario.map.visible_mask(degree)
    d = discretise(
        tracks,
        scenario,
        step_seconds="auto" if step_seconds is None else step_seconds,
        start_time=start_time,
        tolerance=tolerance,
        drop_off_map=drop_off_map,
        visible=visible,
    )
    return LoadedObservations(d.trajectories, fmt.name, d, dict(options.left_out))


def _select_robots(
    tracks: PoseTracks, mapping: Mapping[str, str]
) -> tuple[PoseTracks, dict[str, int]]:
    """The poses of the robots ``mapping`` names (file name -> scenario robot), renamed, as a
    bag's topics are read; and the poses of each robot it does not name, left out."""
    for old in mapping:
        if old not in tracks.robot_names:
            raise PoseError(f"{tracks.source}: `topics` {old}=...: no robot '{old}' in the file")
    counts = np.bincount(tracks.robot, minlength=len(tracks.robot_names))
    left_out = {n: int(counts[i]) for i, n in enumerate(tracks.robot_names) if n not in mapping}
    kept = [i for i, n in enumerate(tracks.robot_names) if n in mapping]
    merged: list[str] = list(dict.fromkeys(mapping[tracks.robot_names[i]] for i in kept))
    lut = np.full(len(tracks.robot_names), -1, dtype=np.int64)
    for i in kept:
        lut[i] = merged.index(mapping[tracks.robot_names[i]])
    rows = lut[tracks.robot] >= 0
    selected = PoseTracks(
        tuple(merged), tracks.t[rows], lut[tracks.robot[rows]], tracks.x[rows], tracks.y[rows],
        tracks.yaw[rows], tracks.source,
    ).sorted()  # fmt: skip
    return selected, left_out
