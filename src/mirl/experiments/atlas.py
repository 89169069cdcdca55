"""The calibration atlas (``mirl experiment atlas``): L's fault verdicts over the inputs users
give, each design point taken through the commands a user types (docs/design.md, "The
calibration atlas").

A design point is a :class:`~mirl.experiments.conditions.Condition`: a world, a scenario, L's
view, a record length and the damaged wheels with their strength. One run of it

1. simulates the world as ``mirl simulate --observations obs.csv --poses poses.csv`` does,
   and once more, with the same seed, into ``--poses poses.mcap`` (a command writes one pose
   file);
2. learns from each file as ``mirl learn --json`` does (:data:`DATA_PATHS`): the grid CSV, the
   pose CSV and the MCAP file, each in a fresh ``mirl`` process;
3. scores each robot's verdict against :func:`damaged_truth`.

The three data paths of a run see the same simulated patrol, so differences between them are
the path's (the pose CSV and the MCAP file hold the same poses: where their verdicts differ, a
reader does). In the grid world the poses are synthesised from the grid states, at 10 Hz with
the physical camera's noise (:data:`POSE_NOISE`); in the physical world they are L's camera
measurements, one per seen robot and step.

The design (:func:`atlas_design`) is seeded and fixed: every healthy cell of world × scenario ×
view × length once, and per world and kind of fault (one wheel, two robots at once, two wheels
of one robot) :data:`DAMAGED_PER_STRATUM` points with scenario, view and length balanced, the
fault's robots, wheels and strength drawn at random, no point twice; then shuffled, so that
any prefix of the sweep (an interrupted or a pilot one) is a random sample of it. ``--runs``
repeats every point with other seeds; ``--seed`` changes the simulations, not the design.
"""

from __future__ import annotations

import itertools
import json
import os
import sys
import zlib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from mirl.physics.config import PhysicsConfig
from mirl.world.faults import WHEELS

if TYPE_CHECKING:
    from mirl.world.scenario import Scenario

__all__ = [
    "DATA_PATHS",
    "DESIGN_SEED",
    "FAULT_KINDS",
    "NO_DAMAGE",
    "POSE_PATHS",
    "AtlasFault",
    "DesignPoint",
    "atlas_design",
    "atlas_run",
    "damaged_truth",
    "damage_flags",
    "fault_kind",
    "format_damage",
    "parse_damage",
    "run_commands",
    "simulation_seed",
    "verdict_metrics",
]

DESIGN_SEED = 39
"""The seed of the committed design."""
WORLD_NAMES = ("grid", "physics")
SCENARIO_ROBOTS: Mapping[str, tuple[str, ...]] = {
    "boyd2-healthy": ("I", "J"),
    "boydright": ("I", "J"),
    "boydright-3": ("I", "J", "K"),
    "office": ("I", "J", "K", "M"),  # a generated 60 x 60 office floor
}
"""The atlas's scenarios and their robots (listed here so that building the design loads no
map; a test checks them against the scenarios)."""
VIEWS = (0.14, 1.0)
LENGTHS = (150, 450, 900)
FAULT_KINDS = ("none", "one wheel", "two robots", "two wheels")
"""No damage; one wheel of one robot; one wheel of each of two robots; both wheels of one
robot."""
STRENGTHS: Mapping[str, tuple[float, ...]] = {"grid": (0.7,), "physics": (0.5, 0.6, 0.8)}
"""A damaged part's value: a success probability on the grid (the paper's damaged wheel), a
motor strength in the physical world."""
DAMAGED_PER_STRATUM = 60
"""Design points per world and kind of damage."""
POSE_NOISE = (PhysicsConfig.measurement_sigma, PhysicsConfig.measurement_sigma_deg)
"""``--pose-noise`` of the grid world's poses: the physical camera's measurement noise (m,
degrees), so that both worlds' pose data are as noisy."""
DATA_PATHS: Mapping[str, str] = {"grid-csv": "grid CSV", "pose-csv": "pose CSV", "mcap": "MCAP"}
"""The files a run learns from, by key (as stored) and in words."""
POSE_PATHS = ("pose-csv", "mcap")
"""The data paths whose files carry poses; both hold the same poses of a run."""
NO_DAMAGE = "none"
"""A condition's ``damage`` when every part is healthy."""
OUTCOME = "learned"
"""A run's outcome: it learned from its files (there is no L to go)."""


class DesignPoint(Protocol):
    """What a run reads of its :class:`~mirl.experiments.conditions.Condition`."""

    @property
    def world(self) -> str:
        """The world's name."""
        ...

    @property
    def scenario(self) -> str:
        """The shipped scenario's name."""
        ...

    @property
    def observability(self) -> float:
        """L's view: the share of the hallway it sees."""
        ...

    @property
    def obs_steps(self) -> int:
        """The record's length in steps."""
        ...

    @property
    def damage(self) -> str | None:
        """The point's faults (:func:`format_damage`)."""
        ...

    @property
    def key(self) -> str:
        """The point's identity (it seeds the run's simulations)."""
        ...


# ---------------------------------------------------------------------------------------------
# Faults


@dataclass(frozen=True)
class AtlasFault:
    """One damaged part of a design point: ``robot``'s ``feature`` at ``value``.

    Parameters
    ----------
    robot : str
        The robot's name.
    feature : str
        The damaged part (a wheel).
    value : float
        Its value: a success probability on the grid, a motor strength in the physical world.
    """

    robot: str
    feature: str
    value: float

    @property
    def flag(self) -> str:
        """As ``--damage`` takes it: ``ROBOT:FEATURE=VALUE``."""
        return f"{self.robot}:{self.feature}={self.value:g}"


def format_damage(faults: Sequence[AtlasFault]) -> str:
    """A condition's ``damage`` field: the faults' ``--damage`` values joined by commas, or
    ``"none"`` (every part healthy, the scenario's own damage included).

    Parameters
    ----------
    faults : sequence of AtlasFault
        The point's faults.

    Returns
    -------
    str
        ``"J:left_wheel=0.6,K:right_wheel=0.6"``, or ``"none"``.
    """
    return ",".join(f.flag for f in faults) or NO_DAMAGE


def parse_damage(damage: str | None) -> tuple[AtlasFault, ...]:
    """The faults of a condition's ``damage`` field (:func:`format_damage`'s inverse).

    Parameters
    ----------
    damage : str or None
        The field; None and ``"none"`` are no fault.

    Returns
    -------
    tuple of AtlasFault
        The faults, in the field's order.

    Raises
    ------
    ValueError
        If an item is not ``ROBOT:FEATURE=VALUE``.
    """
    if damage is None or damage == NO_DAMAGE:
        return ()
    out = []
    for item in str(damage).split(","):
        part, _, value = item.partition("=")
        robot, _, feature = part.partition(":")
        if not (robot and feature and value):
            raise ValueError(f"atlas damage '{damage}': expected ROBOT:FEATURE=VALUE[,…]")
        out.append(AtlasFault(robot, feature, float(value)))
    return tuple(out)


def fault_kind(faults: Sequence[AtlasFault]) -> str:
    """Which of :data:`FAULT_KINDS` ``faults`` are.

    Parameters
    ----------
    faults : sequence of AtlasFault
        A point's faults.

    Returns
    -------
    str
        ``"none"``, ``"one wheel"``, ``"two robots"`` or ``"two wheels"``.
    """
    robots = {f.robot for f in faults}
    if not faults:
        return "none"
    if len(faults) == 1:
        return "one wheel"
    return "two wheels" if len(robots) == 1 else "two robots"


def _faults_of_kind(
    robots: Sequence[str], kind: str, value: float
) -> list[tuple[AtlasFault, ...]]:
    """Every fault of ``kind`` on ``robots`` at ``value``, in a fixed order."""
    if kind == "one wheel":
        return [(AtlasFault(r, w, value),) for r in robots for w in WHEELS]
    if kind == "two wheels":
        return [tuple(AtlasFault(r, w, value) for w in WHEELS) for r in robots]
    if kind == "two robots":
        return [
            (AtlasFault(a, wa, value), AtlasFault(b, wb, value))
            for a, b in itertools.combinations(robots, 2)
            for wa in WHEELS
            for wb in WHEELS
        ]
    raise ValueError(f"unknown kind of fault '{kind}'")


# ---------------------------------------------------------------------------------------------
# The design


def atlas_design(
    seed: int = DESIGN_SEED, damaged_per_stratum: int = DAMAGED_PER_STRATUM
) -> tuple[dict[str, Any], ...]:
    """The design points, as the fields of a :class:`~mirl.experiments.conditions.Condition`
    each, in the order the sweep runs them.

    Parameters
    ----------
    seed : int, default DESIGN_SEED
        Seeds the draws and the order.
    damaged_per_stratum : int, default DAMAGED_PER_STRATUM
        Points per world and damaged kind of fault.

    Returns
    -------
    tuple of dict
        ``method``, ``scenario``, ``observability``, ``obs_steps``, ``world`` and ``damage``
        (:func:`format_damage`) of each point; no two alike.
    """
    rng = np.random.default_rng(seed)
    cells = list(itertools.product(SCENARIO_ROBOTS, VIEWS, LENGTHS))
    # every healthy cell once
    points: list[tuple[str, str, float, int, tuple[AtlasFault, ...]]] = [
        (w, s, d, n, ()) for w in WORLD_NAMES for s, d, n in cells
    ]
    used: set[tuple[Any, ...]] = set()
    for world in WORLD_NAMES:
        for kind in FAULT_KINDS[1:]:
            where = _balanced(rng, len(cells), damaged_per_stratum)
            values = _balanced(rng, len(STRENGTHS[world]), damaged_per_stratum)
            for c, v in zip(where, values, strict=True):
                # a cell whose faults of this kind are all in the design already (two wheels
                # of one of two robots on the grid: two) gives its point to another cell
                for k in itertools.chain((c,), _lazy_permutation(rng, len(cells))):
                    s, d, n = cells[k]
                    fault = _fresh_fault(rng, used, (world, s, d, n), kind, STRENGTHS[world], v)
                    if fault is not None:
                        points.append((world, s, d, n, fault))
                        break
                else:
                    raise ValueError(f"atlas: fewer than {damaged_per_stratum} faults of kind "
                                     f"'{kind}' in the {world} world")  # fmt: skip
    order = rng.permutation(len(points))
    return tuple(
        {
            "method": "mirl-t",
            "scenario": s,
            "observability": d,
            "obs_steps": n,
            "world": w,
            "damage": format_damage(f),
        }
        for w, s, d, n, f in (points[k] for k in order)
    )


def _lazy_permutation(rng: np.random.Generator, k: int) -> Iterator[int]:
    yield from (int(i) for i in rng.permutation(k))


def _balanced(rng: np.random.Generator, k: int, n: int) -> np.ndarray:
    """``n`` indices into ``k`` values, each value ⌊n/k⌋ or ⌈n/k⌉ times, in random order."""
    reps = -(-n // k)
    seq = np.concatenate([rng.permutation(k) for _ in range(reps)])[:n]
    return rng.permutation(seq)


def _fresh_fault(
    rng: np.random.Generator,
    used: set[tuple[Any, ...]],
    cell: tuple[Any, ...],
    kind: str,
    strengths: Sequence[float],
    preferred: int,
) -> tuple[AtlasFault, ...] | None:
    """A fault of ``kind`` on ``cell``'s robots not yet in the design, at the ``preferred``
    strength if one is left there, else at another; None if none is left."""
    robots = SCENARIO_ROBOTS[cell[1]]
    for k in (preferred, *(i for i in range(len(strengths)) if i != preferred)):
        fresh = [f for f in _faults_of_kind(robots, kind, strengths[k]) if (*cell, f) not in used]
        if fresh:
            fault = fresh[int(rng.integers(len(fresh)))]
            used.add((*cell, fault))
            return fault
    return None


# ---------------------------------------------------------------------------------------------
# The truth


@lru_cache(maxsize=8)
def _scenario(name: str) -> Scenario:
    # loading the office generates its map; once per worker process
    from mirl.world.scenario import load_scenario

    return load_scenario(name)


def damage_flags(world: str, scenario: Scenario, faults: Sequence[AtlasFault]) -> list[str]:
    """The ``--damage`` values that make ``scenario`` the design point's: the scenario's own
    damaged parts healed (:func:`_healthy_value`), then ``faults``. The atlas states all of a
    point's damage, so a scenario that ships with a damaged wheel (boydright's J on the grid)
    counts as healthy with no fault.

    Parameters
    ----------
    world : str
        The world's name.
    scenario : Scenario
        The shipped scenario.
    faults : sequence of AtlasFault
        The point's faults.

    Returns
    -------
    list of str
        ``--damage`` values (``ROBOT:FEATURE=VALUE``), the heals first.
    """
    named = {(f.robot, f.feature) for f in faults}
    heal = [
        AtlasFault(robot, part, _healthy_value(world, scenario, robot, part))
        for robot, parts in damaged_truth(world, scenario).items()
        for part in parts
        if (robot, part) not in named
    ]
    return [f.flag for f in (*heal, *faults)]


def _healthy_value(world: str, scenario: Scenario, robot: str, part: str) -> float:
    """The value that makes ``robot``'s ``part`` what an undamaged robot's is in ``world``
    (:meth:`~mirl.worlds.contract.World.healthy_value`: the healthy level on the grid, full
    strength in physics, where a motor at the grid's 0.95 would be weakened)."""
    from mirl.worlds import get_world

    spec = get_world(world).load()
    value = spec.healthy_value(scenario, part)
    if part in spec.damaged_parts(spec.apply_damage(scenario, robot, part, value))[robot]:
        raise ValueError(f"atlas: {world}'s healthy value leaves {robot}'s {part} damaged")
    return value


def damaged_truth(world: str, scenario: Scenario) -> dict[str, tuple[str, ...]]:
    """Per robot, the parts really damaged in ``world``: the one definition the atlas scores
    against, the world's own (:meth:`~mirl.worlds.contract.World.damaged_parts`;
    docs/design.md, "Fault verdicts").

    Parameters
    ----------
    world : str
        The world's name.
    scenario : Scenario
        The scenario, damaged as the run's.

    Returns
    -------
    dict of str to tuple of str
        Per robot, its damaged parts (empty: healthy).
    """
    from mirl.worlds import get_world

    return get_world(world).load().damaged_parts(scenario)


def _with_flags(world: str, scenario: Scenario, flags: Sequence[str]) -> Scenario:
    """``scenario`` with ``--damage`` values applied as the command line applies them."""
    from mirl.worlds import get_world

    apply = get_world(world).load().apply_damage
    for flag in flags:
        (fault,) = parse_damage(flag)
        scenario = apply(scenario, fault.robot, fault.feature, fault.value)
    return scenario


# ---------------------------------------------------------------------------------------------
# The commands


def run_commands(
    condition: DesignPoint, sim_seed: int, flags: Sequence[str], robots: Sequence[str]
) -> dict[str, list[str]]:
    """The ``mirl`` argument lists of one run, by step: ``simulate`` (the grid CSV and the pose
    CSV), ``simulate-mcap`` (the same simulation into an MCAP file) and ``learn.PATH`` per
    :data:`DATA_PATHS` key. Files are named relative to the run's directory.

    Parameters
    ----------
    condition : DesignPoint
        The design point.
    sim_seed : int
        The simulations' ``--seed`` (:func:`simulation_seed`).
    flags : sequence of str
        The ``--damage`` values (:func:`damage_flags`).
    robots : sequence of str
        The scenario's robots (each an MCAP topic ``/R/pose``).

    Returns
    -------
    dict of str to list of str
        The argument lists after ``mirl``, by step.
    """
    from mirl.worlds import get_world

    c = condition
    common = ["--scenario", c.scenario]
    view = ["--observability", f"{c.observability:g}"]
    sim = [
        "simulate", *common, "--world", c.world, *_pairs("--damage", flags),
        "--steps", str(c.obs_steps), "--seed", str(sim_seed), *view, "--random-starts",
    ]  # fmt: skip
    # a world that measures its own poses (L's camera) takes no --pose-noise
    synthesised = not get_world(c.world).records_poses
    noise = ["--pose-noise", *(f"{x:g}" for x in POSE_NOISE)] if synthesised else []
    learn = ["learn", *common, *view, "--json"]
    poses = ["--start-time", "0"]  # the simulation's steps start at t = 0, as it prints
    topics = _pairs("--topic", [f"/{r}/pose={r}" for r in robots])
    return {
        "simulate": [*sim, "--observations", "obs.csv", "--poses", "poses.csv", *noise],
        "simulate-mcap": [*sim, "--observations", "obs-mcap.csv", "--poses", "poses.mcap", *noise],
        "learn.grid-csv": [*learn, "--observations", "obs.csv"],
        "learn.pose-csv": [*learn, "--observations", "poses.csv", *poses],
        "learn.mcap": [*learn, "--observations", "poses.mcap", *topics, *poses],
    }


def _pairs(flag: str, values: Sequence[str]) -> list[str]:
    return [x for v in values for x in (flag, v)]


@dataclass(frozen=True)
class _Finished:
    code: int
    stdout: str
    stderr: str
    cpu: float  # seconds of CPU the process used


def _mirl(argv: Sequence[str], cwd: Path) -> _Finished:
    """``mirl ARGV`` in a fresh process in ``cwd``, as a user runs it; its own CPU time is
    measured from its resource usage (``wait4``), so workers running side by side do not
    count each other's."""
    import subprocess

    out, err = cwd / ".stdout", cwd / ".stderr"
    with out.open("wb") as fo, err.open("wb") as fe:
        proc = subprocess.Popen(
            [sys.executable, "-m", "mirl", *argv],
            cwd=cwd, stdin=subprocess.DEVNULL, stdout=fo, stderr=fe,
        )  # fmt: skip
        _, status, usage = os.wait4(proc.pid, 0)
        proc.returncode = os.waitstatus_to_exitcode(status)
    return _Finished(
        proc.returncode,
        out.read_text(encoding="utf-8"),
        err.read_text(encoding="utf-8"),
        usage.ru_utime + usage.ru_stime,
    )


def _checked(step: str, argv: Sequence[str], done: _Finished) -> None:
    """A simulation must succeed; a failure is the run's error (retried on resume)."""
    if done.code != 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        raise RuntimeError(f"atlas {step} exited {done.code}: {last} (mirl {' '.join(argv)})")


# ---------------------------------------------------------------------------------------------
# One run


def simulation_seed(seed: int, condition: DesignPoint) -> int:
    """The ``--seed`` of a run's simulations: a function of the run's seed and its design
    point, so that points differing only in their length or fault do not replay one patrol.

    Parameters
    ----------
    seed : int
        The run's seed.
    condition : DesignPoint
        The design point (its key).

    Returns
    -------
    int
        A non-negative 63-bit seed.
    """
    ss = np.random.SeedSequence([seed, zlib.crc32(condition.key.encode())])
    return int(ss.generate_state(1, np.uint64)[0] >> np.uint64(1))


def atlas_run(condition: DesignPoint, seed: int) -> dict[str, Any]:
    """One run of a design point (the module's steps 1–3), as a result mapping for the sweep:
    per data path and robot the verdict (``verdict.PATH.R``, the named parts), its confidence,
    whether it is right, its model check where the verdict has one; per robot the truth and the
    steps L saw it; the commands; and the CPU seconds of each command (``timings``).

    A ``mirl learn`` that refuses its file (exit 2: a user's one-line error, such as a robot
    never seen) is recorded as ``refused.PATH`` with its message; any other failure raises.

    Parameters
    ----------
    condition : DesignPoint
        The design point.
    seed : int
        The run's seed.

    Returns
    -------
    dict
        The result mapping (``outcome`` is ``"learned"``: there is no L to go).

    Raises
    ------
    RuntimeError
        If a simulation fails, or a ``mirl learn`` fails other than by refusing its file.
    """
    import tempfile

    faults = parse_damage(condition.damage)
    base = _scenario(condition.scenario)
    flags = damage_flags(condition.world, base, faults)
    truth = damaged_truth(condition.world, _with_flags(condition.world, base, flags))
    sim_seed = simulation_seed(seed, condition)
    commands = run_commands(condition, sim_seed, flags, base.robot_names)
    out: dict[str, Any] = {"outcome": OUTCOME, "sim_seed": sim_seed}
    timings: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="mirl-atlas-") as tmp:
        cwd = Path(tmp)
        for step in ("simulate", "simulate-mcap"):
            done = _mirl(commands[step], cwd)
            _checked(step, commands[step], done)
            timings[step] = done.cpu
        # the MCAP comes from a second simulation: it is the first one's only if both wrote
        # the same grid CSV (MuJoCo is deterministic on one machine)
        out["mcap_same_run"] = int(
            (cwd / "obs.csv").read_bytes() == (cwd / "obs-mcap.csv").read_bytes()
        )
        seen = _seen_steps(cwd / "obs.csv", base.robot_names)
        for path in DATA_PATHS:
            done = _mirl(commands[f"learn.{path}"], cwd)
            timings[f"learn.{path}"] = done.cpu
            out[f"warnings.{path}"] = done.stderr.count("mirl: warning:")
            if done.code == 2:
                out[f"refused.{path}"] = done.stderr.strip().splitlines()[-1]
                continue
            _checked(f"learn.{path}", commands[f"learn.{path}"], done)
            out.update(verdict_metrics(path, json.loads(done.stdout), truth))
    for robot in base.robot_names:
        out[f"truth.{robot}"] = ",".join(truth[robot])
        out[f"weakened.{robot}"] = ",".join(f.feature for f in faults if f.robot == robot)
        out[f"seen.{robot}"] = seen[robot]
    out.update({f"command.{k}": " ".join(["mirl", *v]) for k, v in commands.items()})
    out["timings"] = timings
    return out


def _seen_steps(grid_csv: Path, robots: Sequence[str]) -> dict[str, int]:
    """Per robot, the steps on which L saw it: its rows in the grid CSV."""
    import csv

    counts = dict.fromkeys(robots, 0)
    with grid_csv.open(newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh):
            counts[row["robot"]] += 1
    return counts


def verdict_metrics(
    path: str, record: Mapping[str, Any], truth: Mapping[str, Sequence[str]]
) -> dict[str, Any]:
    """Per robot of ``mirl learn --json``'s ``record`` that has a verdict: the parts it names
    (``verdict.PATH.R``, comma-separated; empty: no part), the parts it says are damaged besides
    them with their probabilities (``also.PATH.R``, where there are any:
    :func:`~mirl.learning.verdicts.also_field`), its confidence, whether it is right
    against ``truth`` (:meth:`~mirl.learning.verdicts.Verdict.is_right`: it names a damaged
    part, or no part of a healthy robot), its model check (``fit.PATH.R``: ``"ok"`` or the
    reason it failed) where the verdict has one, the verdict's probability under L's models
    alone where the check failed (``untempered.PATH.R``), and the observed moves no action explains
    (``unexplained.PATH.R``) where the record counts them.

    Parameters
    ----------
    path : str
        The data path's key (:data:`DATA_PATHS`).
    record : mapping
        ``mirl learn --json``'s output, parsed.
    truth : mapping of str to sequence of str
        Per robot, its damaged parts (:func:`damaged_truth`).

    Returns
    -------
    dict
        The metrics, by ``KIND.PATH.ROBOT``.
    """
    from mirl.learning.verdicts import Verdict, also_field

    out: dict[str, Any] = {}
    for robot, rec in record["robots"].items():
        v = rec.get("verdict")
        if v is None:
            continue
        verdict = Verdict(
            v["part"], float(v["confidence"]), tuple(v["candidates"]),
            v.get("damage_probabilities", {}),
        )  # fmt: skip
        out[f"verdict.{path}.{robot}"] = ",".join(verdict.named)
        if verdict.also:
            out[f"also.{path}.{robot}"] = also_field(verdict)
        out[f"confidence.{path}.{robot}"] = verdict.confidence
        out[f"right.{path}.{robot}"] = int(verdict.is_right(tuple(truth[robot])))
        fit = v.get("fit")
        if isinstance(fit, Mapping):
            out[f"fit.{path}.{robot}"] = "ok" if fit.get("ok") else str(fit.get("reason") or "?")
            if "untempered" in fit:
                out[f"untempered.{path}.{robot}"] = float(fit["untempered"])
        moves = rec.get("observed_moves")
        if isinstance(moves, Mapping) and "unexplained" in moves:
            out[f"unexplained.{path}.{robot}"] = int(moves["unexplained"])
    return out
