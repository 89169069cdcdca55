"""Checks of the command line's inputs and outputs that argparse cannot make: output paths
(before any work is done), observation files that parse but say nothing, and the warnings a
user must see. Every refusal is a :class:`UsageError` (one line, exit 2)."""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

from mirl.world.actions import STEP_SECONDS
from mirl.worlds import get_world

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "UsageError",
    "FIGURE_SUFFIXES",
    "MIN_TRIALS",
    "warn",
    "check_output",
    "check_csv_output",
    "check_distinct",
    "check_pose_flags",
    "check_poses_output",
    "check_experiment_flags",
    "check_damage",
    "damage_unread",
    "check_damage_once",
    "check_observations",
    "check_visible",
    "feature_trials",
    "unique_lowest",
]

FIGURE_SUFFIXES = (".png", ".pdf", ".svg")
# a learned probability resting on fewer observed trials than this is flagged as barely informed
MIN_TRIALS = 10
# `simulate --poses`: poses per robot per step (--pose-rate x --step-seconds; 1000 is 500 Hz at
# the paper's 2 s steps, above any tracker) and per robot in all (--steps x that, were L to see
# every step: 20 000 000 is the defaults' 20 a step over the longest --steps, ~1 GB of poses)
MAX_POSES_PER_STEP = 1000
MAX_POSES = 20_000_000
MAX_POSE_NOISE = (100.0, 360.0)  # metres, degrees: beyond, a pose says nothing of its cell
DEFAULT_POSE_RATE = 10.0  # Hz: `simulate --poses`, a pose tracker's usual rate


class UsageError(Exception):
    """A problem with the user's input, reported in one line."""


def warn(message: str) -> None:
    """Print a warning a user must see on stderr, as ``mirl: warning: MESSAGE``.

    Parameters
    ----------
    message : str
        One line, naming the file or flag it is about.
    """
    print(f"mirl: warning: {message}", file=sys.stderr)


OTHER_FORMATS = (
    ".json", ".mcap", ".bag", ".db3", ".yaml", ".yml", ".toml", ".sqlite", ".parquet", ".png",
    ".pdf", ".svg", ".gif",
)  # fmt: skip
"""Suffixes that name a format other than CSV: a CSV written under one would be misread."""


def check_csv_output(path: str | Path, flag: str) -> Path:
    """:func:`check_output` for a file mirl writes as CSV, refusing a name whose suffix says
    another format (``--truth t.json``), which every reader of it would take at its word.

    Parameters
    ----------
    path : str or Path
        The file to write.
    flag : str
        The flag (or argument) that named it, for the message.

    Returns
    -------
    Path
        ``path``, as a :class:`~pathlib.Path`.

    Raises
    ------
    UsageError
        Its suffix names another format, or :func:`check_output` refuses it.
    """
    p = Path(path)
    if p.suffix.lower() in OTHER_FORMATS:
        raise UsageError(
            f"{flag} {p}: mirl writes it as CSV, which a {p.suffix} name would misname "
            "(name it .csv)"
        )
    return check_output(p, flag)


def check_output(path: str | Path, flag: str, suffixes: tuple[str, ...] | None = None) -> Path:
    """Refuse an output file that cannot be written, before the work that would fill it.

    Parameters
    ----------
    path : str or Path
        The file to write.
    flag : str
        The flag that named it (``--plot``), for the message.
    suffixes : tuple of str, optional
        The lower-case suffixes it may end in (``FIGURE_SUFFIXES``); any if None.

    Returns
    -------
    Path
        ``path``, as a :class:`~pathlib.Path`.

    Raises
    ------
    UsageError
        If its suffix is not one of ``suffixes``, it is a directory, its directory does not
        exist, or it (or its directory) is not writable.
    """
    p = Path(path)
    if suffixes and p.suffix.lower() not in suffixes:
        raise UsageError(f"{flag} {p}: expected a file ending in {', '.join(suffixes)}")
    if p.is_dir():
        raise UsageError(f"{flag} {p}: is a directory")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"{flag} {p}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise UsageError(f"{flag} {p}: not writable")
    return p


def check_distinct(*flags: tuple[str, str | None]) -> None:
    """Refuse two of a command's files that are one file (an output would overwrite an input, or
    one output another), e.g. ``convert run.csv run.csv`` or ``--observations o.csv --truth
    o.csv``.

    Parameters
    ----------
    *flags : tuple of (str, str or None)
        (flag, path) of each file; a None or empty path is not given and skipped.

    Raises
    ------
    UsageError
        If two paths resolve to the same file, naming both flags.
    """
    seen: dict[str, str] = {}
    for flag, path in flags:
        if not path:
            continue
        key = os.path.realpath(path)
        if key in seen:
            raise UsageError(f"{flag} {path}: the same file as {seen[key]}; one would overwrite "
                             "the other")  # fmt: skip
        seen[key] = f"{flag} {path}"


def check_pose_flags(args) -> None:
    """``simulate``'s pose flags: only with ``--poses`` in the grid world (the physics world
    writes its own tracks: L's camera measurements and the true poses at the control rate), and
    within limits; fills in their defaults (``DEFAULT_POSE_RATE``, the grid's step).

    Parameters
    ----------
    args : argparse.Namespace
        ``simulate``'s arguments: ``poses``, ``pose_rate``, ``pose_noise``, ``step_seconds``,
        ``steps`` and ``world``; ``pose_rate`` and ``step_seconds`` are filled in where None.

    Raises
    ------
    UsageError
        If a pose flag is given without ``--poses`` or for a world that records its own poses,
        or the poses per step, the poses in all or the noise exceed their limits.
    """
    given = [
        flag
        for flag, value in (
            ("--pose-rate", args.pose_rate),
            ("--pose-noise", args.pose_noise),
            ("--step-seconds", args.step_seconds),
        )
        if value is not None
    ]
    if given and not args.poses:
        raise UsageError(f"{given[0]} shapes the poses --poses writes; give --poses OUT too")
    if given and get_world(args.world).records_poses:
        raise UsageError(f"{given[0]}: the physics world writes its own tracks (L's camera, and "
                         "the true poses at the control rate); leave it out")  # fmt: skip
    args.pose_rate = DEFAULT_POSE_RATE if args.pose_rate is None else args.pose_rate
    args.step_seconds = STEP_SECONDS if args.step_seconds is None else args.step_seconds
    per_step = args.pose_rate * args.step_seconds
    if per_step > MAX_POSES_PER_STEP:
        raise UsageError(
            f"--pose-rate {args.pose_rate:g} Hz x --step-seconds {args.step_seconds:g} s is "
            f"{per_step:g} poses per step; at most {MAX_POSES_PER_STEP}"
        )
    if per_step * args.steps > MAX_POSES:
        raise UsageError(
            f"--steps {args.steps} x {per_step:g} poses per step (--pose-rate x --step-seconds) "
            f"is up to {per_step * args.steps:g} poses per robot; at most {MAX_POSES:g}"
        )
    for name, value, limit, unit in zip(
        ("SIGMA_M", "SIGMA_DEG"),
        args.pose_noise or (0.0, 0.0),
        MAX_POSE_NOISE,
        (" m", " deg"),
        strict=True,
    ):
        if value > limit:
            raise UsageError(f"--pose-noise {name} must be at most {limit:g}{unit}, got {value:g}")


def check_poses_output(path: str | None, world: str) -> None:
    """``--poses OUT`` before the simulation: a pose CSV, an MCAP file or (grid world) a ROS 2
    bag directory to create, in a directory that exists and can be written.

    Parameters
    ----------
    path : str or None
        ``--poses``'s value; nothing is checked if None or empty.
    world : str
        The world's name (a row of :data:`~mirl.worlds.WORLDS`): a world that records its own
        poses writes no bag directory.

    Raises
    ------
    UsageError
        If the suffix is not one the world writes (``.MCAP`` in capitals included: the reader
        would refuse it), the file cannot be written, an MCAP file exists already, or the bag
        directory cannot be created.
    """
    if not path:
        return
    out = Path(path)
    kinds = (".csv", ".mcap") if get_world(world).records_poses else (".csv", ".mcap", "")
    if out.suffix.lower() not in kinds:
        raise UsageError(
            f"--poses {out}: expected a .csv or .mcap file"
            + (" or a bag directory (no suffix); ROS 1 bags are read, not written" if "" in kinds
               else "")
        )  # fmt: skip
    if out.suffix.lower() == ".mcap" and out.suffix != ".mcap":  # one mirl could not read back
        raise UsageError(
            f"--poses {out}: an MCAP file is read by its lower-case suffix (rosbags tells its "
            f"storage by it); name it {out.with_suffix('.mcap').name}"
        )
    if out.suffix:
        check_output(out, "--poses")
        if out.suffix.lower() == ".mcap" and out.exists():  # the writer never overwrites one
            raise UsageError(f"--poses {out}: exists already, not overwriting an MCAP file")
    elif out.exists():  # the bag writer never writes into an existing directory
        raise UsageError(f"--poses {out}: exists already, not overwriting a bag directory")
    elif not (out.parent.is_dir() and os.access(out.parent, os.W_OK)):
        raise UsageError(f"--poses {out}: cannot create a bag directory there")


def check_experiment_flags(args) -> None:
    """``experiment --out`` must name a directory (or nothing yet), before a sweep creates
    anything (``--dask-scheduler``'s address is checked by its option's declaration).

    Parameters
    ----------
    args : argparse.Namespace
        ``experiment``'s arguments (its ``out``).

    Raises
    ------
    UsageError
        If ``--out`` is empty or names a file.
    """
    if args.out is not None:
        if not args.out.strip():
            raise UsageError("--out: an empty path (leave --out out for results/NAME)")
        if os.path.exists(args.out) and not os.path.isdir(args.out):
            raise UsageError(f"--out {args.out}: is a file, not a directory")


def damage_unread(command: str, args, *, scored: bool = False) -> str | None:
    """Why ``--damage`` changes nothing for a command line, or None where it does: the one list
    of the commands and inputs that never read the scenario's true feature probabilities it
    sets. ``simulate`` and ``run`` simulate with them; ``learn`` reads them to score against
    the truth and, with ``known-r-t``, to label the steps by the true policies; and
    ``learn-transitions --labels true-policy`` labels by those policies.

    Parameters
    ----------
    command : str
        The sub-command.
    args : argparse.Namespace
        Its arguments (``learn``: ``method``; ``learn-transitions``: ``labels``).
    scored : bool, default False
        ``learn``: whether it scores against the scenario's truth (``--compare``).

    Returns
    -------
    str or None
        Why it changes nothing, after ``--damage ...: changes nothing here:``.
    """
    from mirl.learning.methods import METHODS
    from mirl.learning.options import LABELLINGS

    if command == "convert":
        return "convert does not simulate, it places the poses on the map's cells and steps"
    if command == "learn-transitions" and not LABELLINGS[args.labels].reads_truth:
        return f"--labels {args.labels} labels the steps by what L saw, not by the truth"
    if command == "learn" and not scored and not METHODS[args.method].labels_by_truth:
        return (
            f"{args.method} reads no truth and the record is scored against the observed "
            "moves (--compare truth scores it against the damaged scenario)"
        )
    return None


def check_damage(command: str, args, *, scored: bool = False) -> None:
    """Refuse ``--damage`` where it changes nothing (:func:`damage_unread`).

    Parameters
    ----------
    command : str
        The sub-command.
    args : argparse.Namespace
        Its arguments (``damage``: the values given, or None).
    scored : bool, default False
        ``learn``: whether it scores against the scenario's truth.

    Raises
    ------
    UsageError
        If ``--damage`` was given and changes nothing.
    """
    if not getattr(args, "damage", None):
        return
    why = damage_unread(command, args, scored=scored)
    if why is not None:
        raise UsageError(f"--damage {args.damage[0]}: changes nothing here: {why}; leave it out")


def check_damage_once(damage: list[tuple[str, str, float]]) -> None:
    """Refuse a part damaged twice (the last would be kept silently), as a ``--topic`` given
    twice is.

    Parameters
    ----------
    damage : list of (str, str, float)
        The ``--damage`` values parsed: robot, part, value.

    Raises
    ------
    UsageError
        Naming the robot's part and both values.
    """
    seen: dict[tuple[str, str], float] = {}
    for robot, feature, value in damage:
        if (robot, feature) in seen:
            raise UsageError(
                f"--damage {robot}:{feature} given twice ({robot}:{feature}="
                f"{seen[(robot, feature)]:g} and {robot}:{feature}={value:g}); give it once"
            )
        seen[(robot, feature)] = value


def check_observations(path, obs, domain) -> None:
    """Refuse observations with no rows (nothing to learn from) and warn loudly about observed
    steps that no action explains (a robot jumping between cells L saw it on).

    Parameters
    ----------
    path : str or Path
        The file the observations were read from, for the messages.
    obs : Trajectories
        The observations.
    domain : PatrolDomain
        The scenario's domain.

    Raises
    ------
    UsageError
        If ``obs`` has no rows.
    """
    import numpy as np

    from mirl.learning.transitions import observed_steps, perception_labels

    if len(obs) == 0:
        raise UsageError(f"{path}: no observations (a header and no rows): nothing to learn from")
    for i, name in enumerate(obs.robot_names):
        t, s, s_next = observed_steps(obs.state_series(domain, i))
        bad = np.flatnonzero(perception_labels(domain, s, s_next) < 0)
        if bad.size:
            k = int(bad[0])
            a, b = (tuple(int(x) for x in domain.states[v]) for v in (s[k], s_next[k]))
            warn(
                f"{path}: {bad.size} of robot {name}'s {len(t)} observed steps are explained by "
                f"no action (first: t={int(t[k])} {a} -> {b}); they are left out as no trial of "
                "any part, and the verdicts check whether the record fits"
            )


def check_visible(path, obs, domain, visible: np.ndarray, degree: float) -> None:
    """Observed rows where L sees nothing are refused (``--observability 0`` with rows: the
    learner's "unseen means out of view" would contradict every row); rows on cells outside
    L's view are warned about, once, with the first of them.

    Parameters
    ----------
    path : str or Path
        The file the observations were read from, for the messages.
    obs : Trajectories
        The observations.
    domain : PatrolDomain
        The scenario's domain.
    visible : ndarray of shape (S,) of bool
        The states L can see.
    degree : float
        The observability ``visible`` was made at, for the messages.

    Raises
    ------
    UsageError
        If L sees no state at all yet ``obs`` has rows.
    """
    import numpy as np  # here: building the command line loads no numpy

    if np.all(visible) and len(obs):
        # the mirror image: a robot missing from a step was out of L's view, and at this view
        # there is no out of view
        seen = np.zeros((len(obs.robot_names), obs.horizon), dtype=bool)
        seen[obs.robot, obs.t] = True
        missing = ~seen
        if missing.any():
            r, t = np.unravel_index(int(np.argmax(missing)), missing.shape)
            warn(
                f"{path}: L sees every cell at observability {degree:g}, yet the robots are "
                f"missing from {int(missing.sum())} of {missing.size} robot-steps (first: "
                f"{obs.robot_names[r]} at t={int(t)}): the record was made at a narrower view; "
                "give its --observability (or --visible observed)"
            )
        return
    outside = ~np.asarray(visible, dtype=bool)[obs.states(domain)]
    if not outside.any():
        return
    if not np.any(visible):
        raise UsageError(
            f"--observability {degree:g}: L sees no cell, yet {path} has {len(obs)} observed "
            "rows (give the observability they were recorded at)"
        )
    k = int(np.argmax(outside))
    warn(
        f"{path}: {int(outside.sum())} of {len(obs)} observed rows lie on cells L cannot see at "
        f"observability {degree:g} (first: t={int(obs.t[k])} {obs.robot_names[obs.robot[k]]} "
        f"at ({int(obs.row[k])},{int(obs.col[k])})); they are used as observations all the same"
    )


def feature_trials(counts) -> dict[str, int]:
    """Observed trials behind each feature: the trials of every subset that contains it.

    Parameters
    ----------
    counts : SubsetCounts
        A transition-feature learner's pooled counts
        (:class:`~mirl.learning.transitions.SubsetCounts`: its ``subsets`` and their
        ``trials``).

    Returns
    -------
    dict of str to int
        Per feature, its trials.
    """
    out: dict[str, int] = {}
    for subset, n in zip(counts.subsets, counts.trials, strict=True):
        for f in subset:
            out[f] = out.get(f, 0) + int(n)
    return out


def unique_lowest(probs: Mapping[str, float], tol: float = 1e-6) -> str | None:
    """The feature with the single lowest probability; None on a tie (no damaged-part guess).

    Parameters
    ----------
    probs : mapping of str to float
        Per feature, its learned success probability.
    tol : float, default 1e-6
        Probabilities closer than this to the lowest tie with it.

    Returns
    -------
    str or None
        The feature's name, or None if ``probs`` is empty or the lowest ties.
    """
    ranked = sorted(probs.items(), key=lambda kv: kv[1])
    if not ranked or (len(ranked) > 1 and ranked[1][1] - ranked[0][1] <= tol):
        return None
    return ranked[0][0]
