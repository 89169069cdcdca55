"""Pose tracks onto a scenario's grid: the :class:`~mirl.observations.trajectories.Trajectories`
every learner takes, plus a per-robot account of what happened to every pose.

- **Space.** The map frame (``MapFrame``: cell size, centre of cell (0, 0); x east with the
  column, y north with decreasing row) turns (x, y) into fractional (row, col); a pose belongs
  to the nearest cell. A pose on a wall or off the map *snaps* to the nearest patroller cell if
  that cell's square is within half a cell of it; farther away it is an error, or, with
  ``drop_off_map=True``, dropped and counted.
- **Heading.** The nearest of the 4 headings: yaw 0 east (0), π/2 north (1), π west (2), −π/2
  south (3).
- **Time.** Step k is at ``start_time + k·step_seconds``. The default start is the earliest pose
  read, moved by less than half a step to where the record puts its steps
  (:func:`phased_start`): halfway between the moments the robots change cells, when they change
  them in a rhythm of the step (a tracker reporting at their decisions, poses written from grid
  states), so that a step never takes the end of one move and the start of the next.
  Each step takes the robot's pose *nearest* to the step time, if one lies within ``tolerance``
  (default half a step, so every pose is a candidate for exactly one step and none is used
  twice). A step with no pose within the tolerance is unobserved — never interpolated.
  ``n_steps`` defaults to the step nearest the last pose, plus one.
- **The robots' pace.** ``step_seconds="auto"`` takes the longest step at which the robots'
  moves stay within one cell (:func:`auto_step_seconds`): L's models move a robot at most one
  cell a step, and a step longer than a robot's pace makes moves no action explains, while a
  shorter one cuts moves in halves that look like failed steps.

Problems are one-line :class:`DiscretisationError` messages naming the source and robot.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from mirl.observations.phase import cell_changes, step_phase
from mirl.observations.poses import PoseError, PoseTracks
from mirl.observations.trajectories import MAX_TIME, Trajectories
from mirl.world.maps import HEADING_DELTAS, HEADING_YAWS, MAX_FRAME_ORIGIN
from mirl.world.scenario import Scenario

__all__ = [
    "Discretised",
    "DiscretisationError",
    "RobotCounts",
    "discretise",
    "heading_of_yaw",
    "lateral_offset",
    "auto_step_seconds",
    "decision_rhythm",
    "phased_start",
    "rhythm_strength",
    "off_pace",
    "AutoStep",
    "AUTO_LONG_MOVES",
    "AUTO_MIN_MOVES",
    "AUTO_MIN_CHANGES",
    "AUTO_SPARSE",
]

# fraction of a cell a wall/off-map pose may be from a patroller cell and still snap to it
SNAP_CELLS = 0.5
# poses further than this cannot lie on any map (a frame's origin is within 1e7 m of the map
# frame's, maps are far smaller), and times beyond 1e11 s (the year 5138 in epoch seconds) are
# no clock's; checked before arithmetic that would overflow on 1e300
MAX_XY = 2 * MAX_FRAME_ORIGIN
MAX_POSE_TIME = 1e11
# yaws in degrees (:func:`_check_yaw_units`): judged on this many moves, refused when at least
# this share of them agrees with the yaws read as degrees, and this much more than as radians
YAW_UNITS_MIN_MOVES = 20
YAW_UNITS_DEGREES_AT_LEAST = 0.85
YAW_UNITS_MARGIN = 0.2


AUTO_LONG_MOVES = 0.01
"""The share of a record's moves that may span more than one cell at the step
:func:`auto_step_seconds` chooses: a third of the misreads the model check tolerates
(:data:`mirl.learning.model_check.MISREAD_RATE`), which it must not use up."""
AUTO_STEPS = np.round(np.arange(0.1, 10.0 + 1e-9, 0.05), 2)
"""The steps (s) :func:`auto_step_seconds` tries."""
AUTO_MIN_MOVES = 20
"""A step at which fewer consecutive observed steps of a moving robot fall is not judged."""
AUTO_SPARSE = 0.5
"""A tracker that reports a robot this many seconds apart or more is read one pose a step."""
AUTO_MIN_CHANGES = 10
"""Fewer changes of cell than this do not tell a track's period."""
RHYTHM_WINDOW = 0.05
"""A decision rhythm at a step lies within this share of it (the step is chosen in 0.05 s)."""
RHYTHM_NULL = (1.15, 1.85)
"""Periods, in multiples of the step, whose phase concentration is the rhythm's yardstick:
motion that repeats every step (or every half, third … of it) has no component at a period
P·m/n with m ≥ 2, so these periods carry none of a rhythm at the step."""
RHYTHM_CLIP = 0.95
"""A robot's motion is capped at this quantile of its own before its phases are summed."""
RHYTHM_FACTOR = 2.0
"""A rhythm is shown when its concentration is this many times the yardstick's largest."""


class DiscretisationError(PoseError):
    """Poses that cannot be put on the map; the message names the source and robot."""


@dataclass(frozen=True)
class RobotCounts:
    """What happened to one robot's poses.

    Parameters
    ----------
    robot : str
        The robot's name.
    read : int
        Poses read.
    binned : int
        Poses within the tolerance of a step of the watch (candidates for a step).
    snapped : int
        Binned poses on a wall or off the map moved to the nearest patroller cell.
    dropped : int
        Binned poses too far off the hallway, dropped (``drop_off_map=True`` only).
    observed_steps : int
        Steps with a pose: each takes its nearest binned pose.
    outside_visible : int, default 0
        Observed steps on cells outside L's visible cells.
    unplaced : int, default 0
        Stamps read but not placed in the map frame (no transform in time).
    """

    robot: str
    read: int  # poses read
    binned: int  # within the tolerance of a step of the watch (candidates for a step)
    snapped: int  # binned poses on a wall or off the map moved to the nearest patroller cell
    dropped: int  # binned poses too far off the hallway, dropped (drop_off_map=True only)
    observed_steps: int  # steps with a pose: each takes its nearest binned pose
    outside_visible: int = 0  # observed steps on cells outside L's visible cells
    unplaced: int = 0  # stamps read but not placed in the map frame (no transform in time)

    @property
    def no_step(self) -> int:
        """Poses with no step within the tolerance (or outside the watch)."""
        return self.read - self.binned

    @property
    def duplicates(self) -> int:
        """Binned poses of a step that already had a nearer one."""
        return self.binned - self.dropped - self.observed_steps

    def drops(self) -> dict[str, int]:
        """Poses dropped, by reason (docs/design.md, "Frames and TF").

        Returns
        -------
        dict of str to int
            Reason -> poses: off the map, with no step within the tolerance, a duplicate of a
            step's nearer pose, or with no transform to the map frame (zeros included).
        """
        return {
            "off-map": self.dropped,
            "no step within the tolerance": self.no_step,
            "duplicate of a step (the nearest kept)": self.duplicates,
            "no transform to the map frame": self.unplaced,
        }

    def line(self) -> str:
        """The robot's counts in words, one line of :meth:`Discretised.summary`.

        Returns
        -------
        str
            Poses read, binned, snapped, steps observed (and outside L's view) and the drops
            by reason.
        """
        extra = (
            f", {self.outside_visible} outside L's visible cells" if self.outside_visible else ""
        )
        drops = ", ".join(f"{n} {why}" for why, n in self.drops().items() if n)
        return (
            f"{self.robot}: {self.read + self.unplaced} poses read, {self.binned} binned, "
            f"{self.snapped} snapped, {self.observed_steps} steps observed{extra}; "
            f"dropped: {drops or 'none'}"
        )


@dataclass(frozen=True)
class AutoStep:
    """How :func:`auto_step_seconds` chose a step.

    Parameters
    ----------
    seconds : float
        The step chosen.
    long_moves : float
        The share of consecutive observed steps, at that step, whose move spans more than one
        cell.
    why : {"pace", "poses", "multiple", "few moves", "no fit"}
        The robots' pace; the tracker's own interval, at most twice a second (one pose a step);
        a multiple of that interval, at which the robots seen moving move one cell a step (a
        pace the poses cannot tell from robots slowed down alike, see :func:`off_pace`); or
        the paper's 2 s because the robots were not seen moving on enough consecutive steps
        to tell it, or because no step kept their moves within one cell.
    tracker_interval : float, optional
        The time (s) between a sparse tracker's poses (:data:`AUTO_SPARSE` or more), where
        the step is a multiple of it.
    rhythm : bool, optional
        For a smooth track read at its fastest robot's pace: whether some robot's motion keeps
        a rhythm at the step, its decisions (:func:`decision_rhythm`). None where the track
        says its pace otherwise (a tracker's interval, jumps) or none was found.
    """

    seconds: float
    long_moves: float
    why: str = "pace"
    tracker_interval: float | None = None
    rhythm: bool | None = None

    @property
    def found(self) -> bool:
        """Whether the step is the robots' pace or the tracker's interval."""
        return self.why in ("pace", "poses", "multiple")

    def sentence(self) -> str:
        """How the step was chosen, in words.

        Returns
        -------
        str
            The reason (:attr:`why`) and the share of moves spanning more than one cell.
        """
        if self.why == "poses":
            return (
                f"chosen: the tracker's interval, one pose a step; {self.long_moves:.1%} of the "
                "moves span more than one cell"
            )
        if self.why == "multiple":
            return (
                f"chosen: the robots' pace, a multiple of the tracker's interval, at which "
                f"{self.long_moves:.1%} of their moves span more than one cell"
            )
        if self.why == "few moves":
            return "the paper's 2 s: the robots were not seen moving enough to tell their pace"
        if self.why == "no fit":
            return (
                f"the paper's 2 s: no step kept the robots' moves within one cell "
                f"({self.long_moves:.1%} span more at 2 s)"
            )
        return (
            f"chosen: the robots' pace, at which {self.long_moves:.1%} of their moves span "
            "more than one cell"
        )


@dataclass(frozen=True)
class Discretised:
    """Pose tracks on a scenario's grid (:func:`discretise`), and what happened to the poses.

    Parameters
    ----------
    trajectories : Trajectories
        The observed steps, as every learner takes them.
    report : tuple of RobotCounts
        What happened to each robot's poses, in the scenario's order.
    start_time : float
        The time (s) of step 0.
    step_seconds : float
        The step (s).
    tolerance : float
        How far (s) from a step's time a pose may lie and still be its candidate.
    visible : ndarray of bool, shape (rows, cols)
        The cells L could see (see :func:`discretise`).
    auto_step : AutoStep or None, default None
        How the step was chosen when ``step_seconds="auto"``; None when it was given.
    last_pose : float or None, default None
        The time (s) of the latest pose read, whether or not a step took it; None when no pose
        was read. A ``start_time`` after it leaves every pose before the watch.

        .. versionadded:: 0.2.0
    phased : bool, default False
        Whether the start is the earliest pose moved to the phase of the robots' changes of
        cell (:func:`phased_start`), the start not being given.
    """

    trajectories: Trajectories
    report: tuple[RobotCounts, ...]
    start_time: float
    step_seconds: float
    tolerance: float
    visible: np.ndarray  # (rows, cols) bool: the cells L could see (see ``discretise``)
    auto_step: AutoStep | None = None  # how the step was chosen, when it was
    last_pose: float | None = None  # the latest pose's time (s), taken or not
    phased: bool = False  # the default start moved to the phase of the robots' changes of cell

    def visible_states(self, scenario: Scenario) -> np.ndarray:
        """The states on visible cells, for :func:`mirl.learning.learn`'s ``visible``.

        Parameters
        ----------
        scenario : Scenario
            The scenario the tracks were discretised on.

        Returns
        -------
        ndarray of bool, shape (S,)
            Whether each of the scenario's states lies on a cell of :attr:`visible`.
        """
        cells = scenario.domain.states[:, :2]
        return self.visible[cells[:, 0], cells[:, 1]]

    def summary(self) -> str:
        """The discretisation in words: the watch, the step and each robot's counts.

        Returns
        -------
        str
            A header line, then one indented line per robot (:meth:`RobotCounts.line`).
        """
        tr = self.trajectories
        chosen = f", {self.auto_step.sentence()}" if self.auto_step is not None else ""
        phase = ", halfway between the robots' changes of cell" if self.phased else ""
        head = (
            f"{tr.horizon} steps of {self.step_seconds:g} s from t = {self.start_time:.3f} s"
            f"{phase} (tolerance {self.tolerance:g} s{chosen}); {int(self.visible.sum())} cells "
            "visible to L"
        )
        return "\n".join([head, *("  " + c.line() for c in self.report)])


def lateral_offset(rf, cf, row, col, heading, snapped=None) -> np.ndarray:
    """Signed distance of fractional positions from the centre line of their cells.

    Parameters
    ----------
    rf : array_like of float, shape (n,)
        The positions' fractional rows.
    cf : array_like of float, shape (n,)
        Their fractional columns.
    row : array_like of int, shape (n,)
        The row of the cell each is on.
    col : array_like of int, shape (n,)
        Its column.
    heading : array_like of int, shape (n,)
        The heading (0 east, 1 north, 2 west, 3 south) whose centre line is measured from.
    snapped : array_like of bool, shape (n,), optional
        Positions off the hallway, moved onto it; their offset is NaN.

    Returns
    -------
    ndarray of float, shape (n,)
        The distance (cells) from the centre line of cell (row, col) along ``heading``, left of
        the heading positive.
    """
    left = HEADING_DELTAS[(np.asarray(heading) + 1) % 4]  # turn_left's heading: (drow, dcol)
    out = (np.asarray(rf) - row) * left[:, 0] + (np.asarray(cf) - col) * left[:, 1]
    out = np.asarray(out, dtype=float)
    if snapped is not None:
        out[np.asarray(snapped, dtype=bool)] = np.nan
    return out


def heading_of_yaw(yaw: np.ndarray) -> np.ndarray:
    """Nearest of the 4 headings (0 east, 1 north, 2 west, 3 south) of yaw angles.

    Parameters
    ----------
    yaw : array_like of float
        Angles in radians (any range).

    Returns
    -------
    ndarray of int64
        The headings, of ``yaw``'s shape; a yaw half-way between two headings takes the
        even-numbered one (east or west), as :func:`numpy.rint` rounds.
    """
    return np.mod(np.rint(np.asarray(yaw, dtype=float) / (np.pi / 2)), 4).astype(np.int64)


def discretise(
    tracks: PoseTracks,
    scenario: Scenario,
    *,
    step_seconds: float | str = 2.0,
    start_time: float | None = None,
    n_steps: int | None = None,
    tolerance: float | None = None,
    drop_off_map: bool = False,
    visible: np.ndarray | str | None = None,
) -> Discretised:
    """Bin ``tracks`` into the scenario's grid and steps (see the module docstring).

    .. versionchanged:: 0.2.0
       ``step_seconds="auto"``.

    Parameters
    ----------
    tracks : PoseTracks
        The poses; their robots must be among the scenario's.
    scenario : Scenario
        The scenario whose map, robots and observability the poses are read against.
    step_seconds : float or "auto", default 2.0
        The step (s); ``"auto"``: the robots' own pace (:func:`auto_step_seconds`).
    start_time : float, optional
        The time (s) of step 0; by default the earliest pose at the record's phase
        (:func:`phased_start`).
    n_steps : int, optional
        The steps of the watch; by default up to the step nearest the last pose.
    tolerance : float, optional
        How far (s) from a step's time a pose may lie and still be its candidate; half a step
        by default, and at most half a step (a pose is a candidate for its nearest step only).
    drop_off_map : bool, default False
        Drop (and count) poses more than half a cell from the hallway instead of refusing them.
    visible : ndarray of bool of shape (rows, cols), "observed" or None, default None
        Which cells L could see, handed on to the learner: None the scenario's observability
        degree and visibility order; ``"observed"`` every cell a robot was observed on; or a
        mask. Observed steps outside it are counted (``outside_visible``), never dropped.

    Returns
    -------
    Discretised
        The trajectories, each robot's counts, the watch and the visible cells.

    Raises
    ------
    DiscretisationError
        A robot the scenario does not have; a step that is not positive or ``"auto"``; a
        negative tolerance or one over half the step; a NaN, infinite or far-off pose; a start
        time or number of steps out of range; or a pose more than half a cell from the hallway
        without ``drop_off_map``.
    ValueError
        A ``visible`` that is neither None, ``"observed"`` nor a mask of the map's shape.
    """
    auto = None
    if isinstance(step_seconds, str):
        if step_seconds != "auto":
            raise DiscretisationError(
                f"{tracks.source}: `step_seconds` must be a number of seconds or 'auto', got "
                f"{step_seconds!r}"
            )
        # the poses and the watch are checked as at the paper's 2 s before any step is tried
        tracks, _ = _checked(tracks, scenario, 2.0, tolerance)
        _watch(tracks, start_time, n_steps, 2.0)
        auto = auto_step_seconds(tracks, scenario, start_time=start_time)
        step_seconds = auto.seconds
    tracks, tol = _checked(tracks, scenario, step_seconds, tolerance)
    _check_tolerance(tracks.source, tol, step_seconds, auto is not None)
    phased = False
    if start_time is None and len(tracks):
        first = float(tracks.t.min())
        start_time = phased_start(tracks, scenario, step_seconds)
        phased = start_time != first
    start_time, n_steps = _watch(tracks, start_time, n_steps, step_seconds)

    # time: nearest step and the distance to it
    k = np.floor((tracks.t - start_time) / step_seconds + 0.5).astype(np.int64)
    dt = np.abs(tracks.t - (start_time + k * step_seconds))
    binned = (k >= 0) & (k < n_steps) & (dt <= tol * (1 + 1e-12))

    # space: nearest cell, snapping wall / off-map poses
    gridmap = scenario.map
    rf, cf = gridmap.frame.cell_coordinates(tracks.x, tracks.y)
    row, col, ok, snapped = _cells(gridmap.patroller, rf, cf, binned)
    off = binned & ~ok
    if off.any() and not drop_off_map:
        i = int(np.argmax(off))
        raise DiscretisationError(
            f"{tracks.source}: robot {tracks.robot_names[tracks.robot[i]]}: pose "
            f"({tracks.x[i]:.3f}, {tracks.y[i]:.3f}) m"
            f"{tracks.frame_of(tracks.robot_names[tracks.robot[i]])} at t = {tracks.t[i]:.3f} s "
            "is more than "
            f"{SNAP_CELLS:g} cell from the hallway (cell {int(np.floor(rf[i] + 0.5))}, "
            f"{int(np.floor(cf[i] + 0.5))}); check the map frame, or drop such poses explicitly"
        )
    chosen = _nearest_per_step(tracks, k, dt, binned & ok, n_steps)
    heading = heading_of_yaw(tracks.yaw[chosen])
    _check_yaw_units(tracks, chosen, k[chosen], row[chosen], col[chosen], heading)
    traj = Trajectories(
        tracks.robot_names,
        k[chosen],
        tracks.robot[chosen],
        row[chosen],
        col[chosen],
        heading,
        n_steps,
        lateral_offset(
            rf[chosen], cf[chosen], row[chosen], col[chosen], heading, snapped[chosen]
        ),  # fmt: skip
    )
    traj = replace(
        traj,
        off_pace=off_pace(auto),
        tracker_interval=auto.seconds if auto is not None and auto.why == "poses" else None,
        step_given=None if auto is not None else float(step_seconds),
    )
    vis = _visible_mask(visible, scenario, traj)
    n = len(tracks.robot_names)

    def count(mask: np.ndarray, by: np.ndarray = tracks.robot) -> list[int]:
        return np.bincount(by[mask], minlength=n).tolist()

    columns = (
        count(np.ones(len(tracks), dtype=bool)),
        count(binned),
        count(binned & snapped),
        count(off),
        count(np.ones(len(traj), dtype=bool), traj.robot),
        count(~vis[traj.row, traj.col], traj.robot),
    )
    report = tuple(
        replace(RobotCounts(name, *(c[i] for c in columns)), unplaced=tracks.unplaced.get(name, 0))
        for i, name in enumerate(tracks.robot_names)
    )
    last = float(tracks.t.max()) if len(tracks) else None
    return Discretised(
        traj, report, float(start_time), float(step_seconds), tol, vis, auto, last, phased
    )


def _check_yaw_units(tracks: PoseTracks, chosen, k, row, col, heading) -> None:
    """Refuse yaws written in degrees: they are read as radians, and would give every robot
    headings that do not point where it drives.

    A moving robot's yaw points along its moves (a differential drive does not move sideways).
    Over the record's moves to a neighbouring cell at consecutive steps, the heading at either
    end is counted as agreeing when it points along the move. Yaws in radians agree on most
    moves; degrees read as radians point nowhere in particular (about 4 in 10 agree by chance
    when they are noisy; exact multiples of 90° agree where 0°, 90° and −90° alias onto their
    own heading, 3 in 4). Radians read as degrees are all within 3° of east, so they agree only
    on moves east. The refusal asks for both signs — nearly all moves agree as degrees, and
    clearly more than as radians — on :data:`YAW_UNITS_MIN_MOVES` moves or more, so a record
    whose yaws fit neither reading (a frame with y pointing south, a robot driven backwards,
    a tracker that writes no heading) is left to the model check.
    """
    moves = []
    robot = tracks.robot[chosen]
    for i in range(len(tracks.robot_names)):
        at = np.flatnonzero(robot == i)  # sorted by step
        if len(at) < 2:
            continue
        a, b = at[:-1], at[1:]
        dr, dc = row[b] - row[a], col[b] - col[a]
        step = (k[b] - k[a] == 1) & (np.abs(dr) + np.abs(dc) == 1)
        a, b, dr, dc = a[step], b[step], dr[step], dc[step]
        # the heading whose delta is the move: 0 east (0, 1), 1 north (−1, 0), 2 west, 3 south
        direction = np.select([dc == 1, dr == -1, dc == -1], [0, 1, 2], 3)
        moves.append((a, b, direction))
    if not moves:
        return
    a = np.concatenate([m[0] for m in moves])
    b = np.concatenate([m[1] for m in moves])
    direction = np.concatenate([m[2] for m in moves])
    if len(direction) < YAW_UNITS_MIN_MOVES:
        return

    def agree(h: np.ndarray) -> float:
        return float(np.mean((h[a] == direction) | (h[b] == direction)))

    as_radians = agree(heading)
    as_degrees = agree(heading_of_yaw(np.deg2rad(tracks.yaw[chosen])))
    if as_degrees >= YAW_UNITS_DEGREES_AT_LEAST and as_degrees - as_radians >= YAW_UNITS_MARGIN:
        raise DiscretisationError(
            f"{tracks.source}: the yaws point along the robots' moves on {as_radians:.0%} of "
            f"their {len(direction)} moves to a neighbouring cell read as radians and on "
            f"{as_degrees:.0%} read as degrees: give yaw in radians"
        )


def auto_step_seconds(
    tracks: PoseTracks,
    scenario: Scenario,
    *,
    start_time: float | None = None,
    long_moves: float = AUTO_LONG_MOVES,
) -> AutoStep:
    """The robots' pace: the step at which a typical move of theirs is one cell.

    A step longer than a robot's pace lets it cross two cells, which no action explains; a
    shorter one cuts its moves into pieces that stay in one cell and read as failed steps.
    A tracker that reports a robot :data:`AUTO_SPARSE` s apart or more (a camera once a
    decision, an AMCL pose once a second, a publisher stamping in whole seconds; the interval is
    that of its distinct stamps) is read at a multiple of its interval, for no shorter step has a
    pose at both ends: the longest at which the moves stay within one cell, as below, or else
    the interval itself, one pose a step. Other tracks say their pace in two ways:

    * **In jumps** — a tracker reporting at a robot's decisions, poses written from grid
      states: the robot changes cells at multiples of one period (:func:`_jump_period`), its
      pace.
    * **Smoothly** — a robot tracked at 10–30 Hz: the longest of :data:`AUTO_STEPS` at which at
      most ``long_moves`` of the consecutive observed steps move a robot more than one cell
      (by the cells its nearest poses lie in, as :func:`discretise` reads them), of all the
      robots' and of each robot's seen moving on enough steps: the fastest robot sets the
      pace, so that a weak robot's failed moves are not read away by a step long enough for it
      to complete them.

    Steps at which the robots were seen moving on fewer than :data:`AUTO_MIN_MOVES`
    consecutive steps are not judged. When no step fits (poses too noisy to keep a moving
    robot in one cell at any step) or none is judged, the paper's 2 s, and the model check
    will say whether the record fits (:mod:`mirl.learning.model_check`).

    Parameters
    ----------
    tracks : PoseTracks
        The poses, indexed by the scenario's robots.
    scenario : Scenario
        The scenario whose map frame turns positions into cells.
    start_time : float, optional
        The time (s) of step 0; by default the earliest pose at the phase of each step tried
        (:func:`phased_start`).
    long_moves : float, default AUTO_LONG_MOVES
        The share of moves that may span more than one cell at the step chosen.

    Returns
    -------
    AutoStep
        The step, the share of its moves that span more than one cell, and why it was chosen.
    """
    t = np.asarray(tracks.t, dtype=float)
    if not len(t) or not np.isfinite(t).all():
        return AutoStep(2.0, 0.0, "few moves")
    rf, cf = scenario.map.frame.cell_coordinates(tracks.x, tracks.y)
    row, col = np.floor(rf + 0.5).astype(np.int64), np.floor(cf + 0.5).astype(np.int64)
    robots = [np.flatnonzero(tracks.robot == i) for i in range(len(tracks.robot_names))]
    robots = [idx[np.argsort(t[idx], kind="stable")] for idx in robots if len(idx)]
    changes, interval = cell_changes(t, row, col, robots), _pose_interval(t, robots)
    first = float(t.min())

    def start_at(step: float) -> float:
        """Step 0's time at ``step``: the one given, or the phase discretise will read at."""
        return float(start_time) if start_time is not None else step_phase(
            changes, first, step, interval
        )  # fmt: skip

    span = float(t.max()) - first if start_time is None else float(t.max()) - float(start_time)

    def judged(step: float) -> tuple[bool, bool, float]:
        """Whether the robots were seen moving enough at ``step``; whether their moves stay
        within one cell there — every robot's seen moving on enough steps, so that the
        fastest robot sets the pace, and a weak robot's failed moves are not read away; and
        the share of all moves that span more."""
        pairs = long = moved = 0
        each = True
        if span / step + 1 >= MAX_TIME:  # more steps than any record may hold
            return False, False, 0.0
        start = start_at(step)
        for idx in robots:
            cells = _cells_at_steps(t[idx], row[idx], col[idx], start, step)
            both = (cells[:-1, 0] != _UNSEEN) & (cells[1:, 0] != _UNSEEN)
            dist = np.abs(cells[1:] - cells[:-1]).sum(axis=1)[both]
            own_long, own_moved = int((dist >= 2).sum()), int((dist >= 1).sum())
            if own_moved >= AUTO_MIN_MOVES:
                each &= own_long <= long_moves * len(dist)
            pairs, long, moved = pairs + len(dist), long + own_long, moved + own_moved
        enough = moved >= AUTO_MIN_MOVES
        share = long / pairs if pairs else 0.0
        return enough, enough and each and share <= long_moves, share

    pose_interval = interval
    if pose_interval >= AUTO_SPARSE:  # no step between two of its poses has one
        enough, _, share = judged(round(pose_interval, 3))
        if enough:
            # a longer step needs a pose at both ends too: a multiple of the interval, the
            # longest at which the moves stay within one cell (a robot slower than its tracker)
            chosen = AutoStep(round(pose_interval, 3), share, "poses")
            for k in range(2, int(AUTO_STEPS[-1] / pose_interval) + 1):
                _, fits, share = judged(round(k * pose_interval, 3))
                if fits:
                    chosen = AutoStep(
                        round(k * pose_interval, 3), share, "multiple", round(pose_interval, 3)
                    )
            return chosen
    period = _jump_period(t, row, col, robots)
    if period is not None:
        _, fits, share = judged(period)
        if fits:
            return AutoStep(period, share)
    best: AutoStep | None = None
    judged_any = False
    for step in AUTO_STEPS:
        enough, fits, share = judged(float(step))
        judged_any |= enough
        if fits:
            best = AutoStep(float(step), share)
    if best is not None:
        yaw = np.asarray(tracks.yaw, dtype=float)
        tracked = [(t[idx], rf[idx], cf[idx], yaw[idx]) for idx in robots]
        return replace(best, rhythm=decision_rhythm(tracked, best.seconds))
    if not judged_any:
        return AutoStep(2.0, 0.0, "few moves")
    return AutoStep(2.0, judged(2.0)[2], "no fit")


def off_pace(auto: AutoStep | None) -> str:
    """Why the step a record was read at may be no healthy robot's pace; empty when nothing says
    so.

    A record a sparse tracker reports is read at the longest multiple of its interval at which
    the moves stay within one cell (:func:`auto_step_seconds`). Where that is a multiple and
    not the interval itself, the poses fit two paces — robots that slowed down alike (every
    motor weak, crawling a fraction of a cell a step) and a tracker that reports more often
    than healthy robots decide — and a move completed at the one step is a failed move at the
    other: with no robot that moves a cell a step at the interval, nothing in the record is a
    healthy pace to judge the others' failures against (the model check's "pace",
    :func:`mirl.learning.model_check.check_pace`). A step the user gives is the robots' pace by
    their word. A smooth track is read at its fastest robot's speed, which robots slowed down
    alike set as well as healthy ones; it is flagged where no robot's motion keeps a
    rhythm at that step (:func:`decision_rhythm`): a robot that finishes its moves in time
    stops onto each cell at its decisions, and its rhythm is the healthy pace the others'
    failures are judged against. A record read at the interval itself is flagged by its robots'
    moves, which need the grid states (:func:`mirl.learning.verdicts.record_off_pace`).

    Parameters
    ----------
    auto : AutoStep or None
        How the step was chosen (None: the user gave it).

    Returns
    -------
    str
        The reason in words, or "".

    .. versionchanged:: 0.2.0
        A smooth track in which no robot keeps a decision rhythm at the step is flagged.
    """
    if auto is not None and auto.why == "pace" and auto.rhythm is False:
        return (
            f"the poses move smoothly, and no robot's moves keep a rhythm at {auto.seconds:g} s, "
            "the step the fastest robot's speed sets: robots slowed down alike, which drive on "
            "through their decisions without finishing a move, and healthy robots that cross a "
            f"cell every {auto.seconds:g} s without stopping give such poses — the poses cannot "
            "tell which, and a move completed at the one step is a failed move at the other"
        )
    if auto is None or auto.why != "multiple":
        return ""
    return (
        f"the robots' moves stay within one cell at {auto.seconds:g} s, a multiple of the "
        f"tracker's interval ({auto.tracker_interval:g} s), so at the interval they cross a "
        "cell at most every other step: robots slowed down alike, or a tracker that reports "
        "more often than they decide — the poses cannot tell which, and a move completed "
        "at the one step is a failed move at the other"
    )


def decision_rhythm(tracked, step: float) -> bool:
    """Whether some robot's motion keeps a rhythm at ``step``: its decisions.

    A patroller decides a move, drives it and decides again; a robot that finishes its move
    within a decision slows down onto the cell and starts again at the next one, so its
    motion repeats at its decision interval. Robots slowed down alike (weak motors) never
    finish a move in time and drive on through their decisions; a smooth track reads them at
    their own, slower pace, as if healthy, and at that pace their motion keeps no rhythm. The
    rhythm is shown where :func:`rhythm_strength` exceeds :data:`RHYTHM_FACTOR` for some
    robot.

    Parameters
    ----------
    tracked : sequence of (ndarray, ndarray, ndarray, ndarray)
        Per robot its poses' times (s, sorted), fractional rows and columns, and yaws (rad).
    step : float
        The step (s) whose rhythm is asked.

    Returns
    -------
    bool
        True when some robot's moves keep a rhythm at the step.
    """
    return any(
        rhythm_strength(t, row, col, yaw, step) > RHYTHM_FACTOR for t, row, col, yaw in tracked
    )


def rhythm_strength(t, row, col, yaw, step: float) -> float:
    """How strongly one robot's motion keeps a rhythm at ``step``.

    The robot's motion aₖ is its speed (cells a second) plus its turn rate (quarter turns a
    second), each over a quarter of the step — long enough that a tracker's noise of a few
    centimetres and degrees does not swamp it, short enough to resolve a move — capped at their
    :data:`RHYTHM_CLIP` quantile so that a few outliers (a yaw that flips, a pose that jumps)
    do not outweigh the rest. Its phase concentration at a period P is
    z(P) = |Σₖ aₖ e^{2πi tₖ/P}| / Σₖ aₖ: near 0 for a robot that drives on at a steady or
    wandering speed, large for one that starts and stops with its decisions. The strength is
    the largest z within :data:`RHYTHM_WINDOW` of ``step`` over the largest at the periods of
    :data:`RHYTHM_NULL`, which a rhythm at the step does not reach: motion repeating every step
    has no component at P·m/n for m ≥ 2. Computed by one FFT of the motion binned at a
    twentieth of the step or the poses' interval, whichever is shorter (a phase error of at most
    π/20), zero-padded to a quarter of a cycle's drift over the record between neighbouring
    frequencies. A span over a gap of the track (a robot out of view) is left out, and so is one
    whose motion overflows (stamps a few ulps apart).

    Parameters
    ----------
    t : ndarray of shape (n,)
        The robot's pose times (s), sorted.
    row, col : ndarray of shape (n,)
        Its fractional cell coordinates.
    yaw : ndarray of shape (n,)
        Its yaws (rad).
    step : float
        The step (s).

    Returns
    -------
    float
        The ratio; 0 for a robot with too few poses or no motion.
    """
    gaps = np.diff(t)
    gaps = gaps[gaps > 0]  # a stamp shared by two poses is no interval
    if len(t) < 4 or not len(gaps):
        return 0.0
    interval = float(np.median(gaps))
    lag = max(1, int(round(step / 4 / max(interval, 1e-3))))
    if len(t) <= lag:
        return 0.0
    span_k = t[lag:] - t[:-lag]
    ok = (span_k > 0) & (span_k <= 1.5 * lag * interval)  # no gap inside the span
    safe = np.where(ok, span_k, 1.0)
    # Stamps a few ulps apart give a motion beyond the floats (inf): no tracker measures that,
    # so such a span is left out like one over a gap; finite motions keep their bits.
    with np.errstate(over="ignore"):
        speed = np.hypot(row[lag:] - row[:-lag], col[lag:] - col[:-lag]) / safe
        turn = np.abs((yaw[lag:] - yaw[:-lag] + np.pi) % (2 * np.pi) - np.pi) / safe / (np.pi / 2)
        motion = speed + turn
    ok &= np.isfinite(motion)
    a = motion[ok]
    at = (0.5 * (t[lag:] + t[:-lag]))[ok]
    if not len(a):
        return 0.0
    a = np.minimum(a, np.quantile(a, RHYTHM_CLIP))
    if a.sum() <= 0:
        return 0.0
    span = float(at[-1] - at[0])
    width = max(min(step / 20, max(interval, 1e-3)), span / 2**22)  # bounded memory
    bins = np.zeros(int(span / width) + 1)
    np.add.at(bins, np.minimum((at - at[0]) / width, len(bins) - 1).astype(np.int64), a)
    n = 1 << int(np.ceil(np.log2(4 * len(bins))))
    z = np.abs(np.fft.rfft(bins, n)) / a.sum()
    freq = np.fft.rfftfreq(n, width)

    def largest(lo: float, hi: float) -> float:
        inside = (freq >= 1 / (hi * step)) & (freq <= 1 / (lo * step))
        return float(z[inside].max()) if inside.any() else 0.0

    null = largest(*RHYTHM_NULL)
    peak = largest(1 - RHYTHM_WINDOW, 1 + RHYTHM_WINDOW)
    return peak / null if null > 0 else 0.0


def _pose_interval(t: np.ndarray, robots: list[np.ndarray]) -> float:
    """The median time between a robot's consecutive distinct stamps (0 if it has none).

    Equal stamps are left out: a publisher that stamps in whole seconds gives many poses one
    stamp, and their zero gaps would make the interval 0, a step no record can be read at."""
    ticks = [np.diff(np.unique(t[idx])) for idx in robots if len(idx) > 1]
    gaps = np.concatenate(ticks) if ticks else np.zeros(0)
    return float(np.median(gaps)) if gaps.size else 0.0


def _jump_period(t, row, col, robots: list[np.ndarray]) -> float | None:
    """The period of a track whose robots change cells in jumps (class docstring of
    :func:`auto_step_seconds`), or None for one that moves smoothly.

    A track that changes cell between a quarter or more of its consecutive poses reports at the
    robots' pace or slower: its pose interval. Otherwise the period is the longest of the lower
    quartile of the times between changes of cell, and its halves, thirds, … down to two pose
    intervals, of which at least 80 % of those times are multiples, within a pose interval or a
    tenth of the period, whichever is less."""
    gaps, pairs, changed = [], 0, 0
    for idx in robots:
        ti = t[idx]
        if len(ti) < 2:
            continue
        moved = (row[idx][1:] != row[idx][:-1]) | (col[idx][1:] != col[idx][:-1])
        pairs, changed = pairs + len(moved), changed + int(moved.sum())
        gaps.append(np.diff(0.5 * (ti[1:] + ti[:-1])[moved]))
    pose_interval = _pose_interval(t, robots)
    if not gaps or sum(len(g) for g in gaps) < AUTO_MIN_CHANGES or pose_interval <= 0.0:
        return None
    if changed >= 0.25 * pairs:
        return round(pose_interval, 3)
    between = np.concatenate(gaps)
    lower = float(np.quantile(between, 0.25))  # out-of-view spells make the longer ones
    k = 1
    while lower / k >= 2 * pose_interval:
        period = lower / k
        off = np.abs(between / period - np.rint(between / period)) * period
        if np.mean(off <= min(pose_interval, 0.1 * period)) >= 0.8:
            return round(period, 3)
        k += 1
    return None


def phased_start(tracks: PoseTracks, scenario: Scenario, step_seconds: float) -> float:
    """The time of step 0 when none is given: the earliest pose, moved by at most half a step to
    the phase at which the robots change cells between steps.

    A robot that acts in steps changes cells once a step, at the same phase of every step: a
    tracker reporting at its decisions, poses written from grid states (``mirl simulate
    --poses``, which writes each step's poses from half a step before its time to half a step
    after) or a robot that stops onto its cells at its decisions change cells halfway between
    two decisions. Steps put at the earliest pose, whatever its phase, would read the end of
    one move and the start of the next as two steps on one cell — a stall at the edge of every
    stretch the robot was in view, and at worst every move cut in two; the poses' own phase puts
    each step where its state is: the mean of the changes' phases as angles of the step
    (:func:`mirl.observations.phase.step_phase`), where they keep one; otherwise (a smooth
    track at a speed of its own, few moves), and for a tracker that reports at most twice a
    step, whose poses are the steps' times, the earliest pose. The step nearest the earliest pose is
    step 0, so the watch keeps every pose.

    .. versionadded:: 0.2.0

    Parameters
    ----------
    tracks : PoseTracks
        The poses, indexed by the scenario's robots.
    scenario : Scenario
        The scenario whose map frame turns positions into cells.
    step_seconds : float
        The step (s).

    Returns
    -------
    float
        The start (s), within half a step of the earliest pose; 0 for no poses.
    """
    t = np.asarray(tracks.t, dtype=float)
    if not len(t):
        return 0.0
    rf, cf = scenario.map.frame.cell_coordinates(tracks.x, tracks.y)
    row, col = np.floor(rf + 0.5).astype(np.int64), np.floor(cf + 0.5).astype(np.int64)
    robots = [np.flatnonzero(tracks.robot == i) for i in range(len(tracks.robot_names))]
    robots = [idx[np.argsort(t[idx], kind="stable")] for idx in robots if len(idx)]
    changes, interval = cell_changes(t, row, col, robots), _pose_interval(t, robots)
    return step_phase(changes, float(t.min()), float(step_seconds), interval)


_UNSEEN = np.iinfo(np.int64).min


def _cells_at_steps(t, row, col, start: float, step: float) -> np.ndarray:
    """(steps, 2) the cell of the pose nearest each step time within half a step (ties: the
    earlier pose), :data:`_UNSEEN` where there is none; ``t`` sorted."""
    k = np.arange(int(np.floor((t[-1] - start) / step + 0.5)) + 1)
    times = start + k * step
    right = np.clip(np.searchsorted(t, times), 0, len(t) - 1)
    left = np.clip(right - 1, 0, len(t) - 1)
    nearest = np.where(np.abs(t[left] - times) <= np.abs(t[right] - times), left, right)
    ok = np.abs(t[nearest] - times) <= step / 2 * (1 + 1e-12)
    out = np.full((len(k), 2), _UNSEEN, dtype=np.int64)
    out[ok] = np.column_stack([row[nearest[ok]], col[nearest[ok]]])
    return out


def _watch(
    tracks: PoseTracks, start_time: float | None, n_steps: int | None, step_seconds: float
) -> tuple[float, int]:
    """The watch's start (default: the first pose) and number of steps (default: up to the last
    pose), each checked against its limit."""
    if start_time is None:
        start_time = float(tracks.t.min()) if len(tracks) else 0.0
    elif not (np.isfinite(start_time) and abs(start_time) <= MAX_POSE_TIME):
        raise DiscretisationError(
            f"{tracks.source}: start time {start_time:g} s is not a time within "
            f"{MAX_POSE_TIME:g} s of 0 (epoch seconds or simulation time)"
        )
    if n_steps is None:
        last = float(tracks.t.max()) if len(tracks) else start_time
        n_steps = _steps_spanned(tracks, start_time, last, step_seconds)
    if not 0 <= n_steps <= MAX_TIME:
        raise DiscretisationError(
            f"{tracks.source}: n_steps must be in [0, {MAX_TIME}], got {n_steps}"
        )
    return start_time, n_steps


def _steps_spanned(tracks: PoseTracks, start: float, last: float, step_seconds: float) -> int:
    """Steps from ``start`` to the last pose, refused past :data:`MAX_TIME` before anything
    that size is allocated: a record mixing epoch stamps (~1.7e9 s) with simulation time
    would otherwise ask for gigabytes."""
    span = (last - start) / step_seconds
    if span + 0.5 >= MAX_TIME:
        raise DiscretisationError(
            f"{tracks.source}: the poses span {last - start:.6g} s from t = {start:.6g} s, "
            f"{span:.3g} steps of {step_seconds:g} s, more than the limit of {MAX_TIME} steps "
            "(mixed clocks, e.g. epoch and simulation time? or a later `start_time`)"
        )
    return max(int(np.floor(span + 0.5)) + 1, 0)


def _checked(tracks: PoseTracks, scenario: Scenario, step_seconds: float, tolerance):
    """Tracks indexed by the scenario's robots, NaN-free; the tolerance."""
    src = tracks.source
    if not (np.isfinite(step_seconds) and step_seconds > 0):
        raise DiscretisationError(f"{src}: step_seconds must be positive, got {step_seconds}")
    tol = step_seconds / 2.0 if tolerance is None else float(tolerance)
    if not (np.isfinite(tol) and tol >= 0):
        raise DiscretisationError(f"{src}: tolerance must be a non-negative number, got {tol}")
    try:
        tracks = tracks.with_robot_names(scenario.robot_names)
    except PoseError as exc:
        raise DiscretisationError(str(exc)) from None
    bad = ~np.isfinite(np.column_stack([tracks.t, tracks.x, tracks.y, tracks.yaw])).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        name = tracks.robot_names[tracks.robot[i]]
        raise DiscretisationError(f"{src}: robot {name}: NaN or infinite pose at t = {tracks.t[i]}")
    far = (np.abs(tracks.t) > MAX_POSE_TIME) | (np.maximum(abs(tracks.x), abs(tracks.y)) > MAX_XY)
    if far.any():  # checked before any arithmetic that could overflow on them
        i = int(np.argmax(far))
        name = tracks.robot_names[tracks.robot[i]]
        raise DiscretisationError(
            f"{src}: robot {name}: pose ({tracks.x[i]:.6g}, {tracks.y[i]:.6g}) m at t = "
            f"{tracks.t[i]:.6g} s is beyond the limits of {MAX_XY:g} m and {MAX_POSE_TIME:g} s"
        )
    return tracks, tol


def _check_tolerance(src: str, tol: float, step_seconds: float, chosen: bool) -> None:
    """Refuse a tolerance over half a step: a pose is a candidate for its nearest step only (so
    that no pose is used twice), which already lies within half a step, so a larger tolerance
    would change nothing while the summary stated it."""
    half = step_seconds / 2.0
    if tol > half * (1 + 1e-12):
        which = " chosen from the robots' pace (give `step_seconds` to choose it)" if chosen else ""
        raise DiscretisationError(
            f"{src}: `tolerance` {tol:g} s is more than half the step of {step_seconds:g} s"
            f"{which}: a pose counts only for its nearest step, never one farther than "
            f"{half:g} s; give a tolerance of at most {half:g} s"
        )


def _nearest_per_step(tracks: PoseTracks, k, dt, keep, n_steps: int) -> np.ndarray:
    """Row index of the nearest kept pose per (robot, step) (ties: the earlier pose), sorted by
    (step, robot)."""
    idx = np.flatnonzero(keep)
    key = tracks.robot[idx] * max(n_steps, 1) + k[idx]
    order = np.lexsort((tracks.t[idx], dt[idx], key))
    idx, key = idx[order], key[order]
    first = np.ones(len(idx), dtype=bool)
    first[1:] = key[1:] != key[:-1]
    chosen = idx[first]
    return chosen[np.lexsort((tracks.robot[chosen], k[chosen]))]


def _visible_mask(visible, scenario: Scenario, traj: Trajectories) -> np.ndarray:
    gridmap = scenario.map
    if visible is None:
        return gridmap.visible_mask(scenario.observability)
    if isinstance(visible, str):
        if visible != "observed":
            raise ValueError(f"visible must be None, 'observed' or a mask, got {visible!r}")
        vis = np.zeros(gridmap.shape, dtype=bool)
        vis[traj.row, traj.col] = True
        return vis
    vis = np.asarray(visible, dtype=bool)
    if vis.shape != gridmap.shape:
        raise ValueError(f"visible mask has shape {vis.shape}, the map {gridmap.shape}")
    return vis


def _cells(patroller: np.ndarray, rf: np.ndarray, cf: np.ndarray, which: np.ndarray):
    """Nearest patroller cell of fractional (row, col) positions.

    Returns row, col (int64), ok (on a patroller cell, or snapped to one within SNAP_CELLS) and
    snapped (moved to a neighbouring cell); only positions in ``which`` are examined.
    """
    rows, cols = patroller.shape
    n = len(rf)
    r = np.floor(rf + 0.5).astype(np.int64)
    c = np.floor(cf + 0.5).astype(np.int64)
    inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
    on = np.zeros(n, dtype=bool)
    on[inside] = patroller[r[inside], c[inside]]
    ok = on.copy()
    snapped = np.zeros(n, dtype=bool)
    todo = np.flatnonzero(which & ~on)
    if todo.size:
        best_d = np.full(todo.size, np.inf)
        best_r = r[todo].copy()
        best_c = c[todo].copy()
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                rr, cc = r[todo] + dr, c[todo] + dc
                valid = (rr >= 0) & (rr < rows) & (cc >= 0) & (cc < cols)
                valid[valid] = patroller[rr[valid], cc[valid]]
                # distance from the point to the cell's square, in cells
                gr = np.maximum(np.abs(rf[todo] - rr) - 0.5, 0.0)
                gc = np.maximum(np.abs(cf[todo] - cc) - 0.5, 0.0)
                d = np.where(valid, np.hypot(gr, gc), np.inf)
                better = d < best_d
                best_d[better], best_r[better], best_c[better] = d[better], rr[better], cc[better]
        good = best_d <= SNAP_CELLS + 1e-12
        r[todo[good]], c[todo[good]] = best_r[good], best_c[good]
        ok[todo[good]] = True
        snapped[todo[good]] = True
    return r, c, ok, snapped


def poses_from_trajectories(
    trajectories: Trajectories,
    scenario: Scenario,
    *,
    step_seconds: float = 2.0,
    rate_hz: float = 10.0,
    start_time: float = 0.0,
    sigma_xy: float = 0.0,
    sigma_yaw_degrees: float = 0.0,
    seed: int | None = None,
    source: str = "<simulated>",
) -> PoseTracks:
    """Continuous poses of grid observations, as a tracker at ``rate_hz`` would report them.

    An observation at step k becomes poses at the cell centre and heading's yaw, every
    1/``rate_hz`` s strictly inside the step's own window ``(t_k − step/2, t_k + step/2)`` around
    ``t_k = start_time + k·step_seconds`` (times before ``start_time`` left out), one of them at
    ``t_k`` exactly; Gaussian noise of ``sigma_xy`` metres per axis and ``sigma_yaw_degrees`` is
    added. An unobserved step has no poses, so :func:`discretise` recovers the observations
    (up to the noise).
    """
    if rate_hz <= 0 or not np.isfinite(rate_hz):
        raise ValueError(f"pose rate must be positive, got {rate_hz}")
    if sigma_xy < 0 or sigma_yaw_degrees < 0:
        raise ValueError("pose noise must not be negative")
    period = 1.0 / rate_hz
    half = int(np.ceil(step_seconds / 2 / period - 1e-9)) - 1  # strictly inside the window
    offsets = np.arange(-half, half + 1) * period  # includes 0
    tr = trajectories
    t = start_time + (tr.t[:, None] * step_seconds + offsets[None, :])
    keep = t >= start_time - 1e-12
    rep = keep.sum(axis=1)
    x, y = scenario.map.frame.cell_centre(tr.row, tr.col)
    yaw = HEADING_YAWS[tr.heading]
    x, y, yaw, robot = (np.repeat(v, rep) for v in (x, y, yaw, tr.robot))
    t = t[keep]
    rng = np.random.default_rng(seed)
    if sigma_xy > 0:
        x = x + rng.normal(0.0, sigma_xy, len(x))
        y = y + rng.normal(0.0, sigma_xy, len(y))
    if sigma_yaw_degrees > 0:
        yaw = yaw + np.deg2rad(rng.normal(0.0, sigma_yaw_degrees, len(yaw)))
        yaw = np.angle(np.exp(1j * yaw))
    return PoseTracks(tr.robot_names, t, robot, x, y, yaw, source).sorted()
