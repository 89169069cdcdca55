""":func:`check_world`: whether a world keeps the contract of :mod:`mirl.worlds.contract`, as
gymnasium's ``check_env`` checks an environment.

mypy checks the contract's types (each world module assigns its class to a
:class:`~mirl.worlds.contract.World`); this checks what types cannot say, on a few steps of a
real scenario: shapes and ranges of everything a run reads, that the step counter and the
records advance together, that a seed fixes a run and a simulation, that refused input moves
nothing, and that damage, the modelled scenario, the damaged parts, the version, the scenario
section and ``simulate`` answer as documented. A test runs it on every row of
:data:`mirl.worlds.WORLDS`.
"""

from __future__ import annotations

import json
from typing import Any, cast

import numpy as np

from mirl.observations.trajectories import Trajectories
from mirl.planning.observer import ObserverModel, observer_model
from mirl.world.domain import ACTIONS
from mirl.world.scenario import Scenario, as_scenario
from mirl.worlds.contract import Detection, RunSetup, RunWorld, Simulation, World
from mirl.worlds.registry import WorldSpec, check_row

__all__ = ["check_world", "WorldContractError"]

# a damage value that is damage in every world (the rows give their own)
_DAMAGE = 0.5


class WorldContractError(AssertionError):
    """A world that breaks its contract; the message names the world and the member."""


def check_world(
    world: WorldSpec | World,
    scenario: Scenario | str = "boyd2",
    *,
    steps: int = 4,
    seed: int = 0,
) -> None:
    """Check that ``world`` keeps the world contract on ``scenario``.

    Parameters
    ----------
    world : WorldSpec or World
        A row of :data:`~mirl.worlds.WORLDS` (its class is loaded, and the row's promises —
        ``records_poses``, ``experiment_damage`` — are checked too), or a world's class.
    scenario : Scenario or str, default "boyd2"
        Where to check it; at least two robots, as every scenario has.
    steps : int, default 4
        Steps of each run and simulation (a few keep the check fast in physics).
    seed : int, default 0
        The seed of the runs and simulations checked for determinism.

    Raises
    ------
    WorldContractError
        The first broken promise, naming the world and the member.
    """
    row = world if isinstance(world, WorldSpec) else None
    if row is not None:
        check_row(row)
    cls = row.load() if row is not None else cast(World, world)
    name = row.name if row is not None else getattr(cls, "__name__", repr(cls))
    sc = as_scenario(scenario)
    model = observer_model(sc)

    def need(ok: Any, what: str) -> None:
        if not ok:
            raise WorldContractError(f"world '{name}': {what}")

    _check_runs(cls, sc, model, steps, seed, need)
    _check_patroller_actions(cls, sc, model, seed, need)
    _check_simulate(cls, sc, steps, seed, need, row)
    _check_scenario_methods(cls, sc, need, row)


def _setup(sc: Scenario, model: ObserverModel, seed: int) -> RunSetup:
    noise = np.random.SeedSequence(seed).spawn(1)[0]
    return RunSetup(sc, model, sc.observability, seed, noise)


def _record(w: RunWorld, sc: Scenario, model: ObserverModel, need) -> tuple:
    """The run's state now, checked for shapes and ranges; compared between two runs."""
    n, n_states = len(sc.robots), sc.domain.n_states
    need(len(w.seen) == len(w.true) == w.t + 1, "seen and true hold one entry per step, t + 1")
    seen, true = w.seen[-1], w.true[-1]
    for what, a, low in (("seen", seen, -1), ("true", true, 0)):
        need(
            isinstance(a, np.ndarray) and a.shape == (n,) and np.issubdtype(a.dtype, np.integer),
            f"{what}[t] is an (N,) integer array",
        )
        need(((a >= low) & (a < n_states)).all(), f"{what}[t] holds state indices (>= {low})")
    need(w.visible[seen[seen >= 0]].all(), "L sees patrollers only on its visible states")
    if w.seen_lateral is not None:
        lat = w.seen_lateral[-1]
        need(len(w.seen_lateral) == w.t + 1 and lat.shape == (n,), "seen_lateral[t] is (N,)")
        need((np.isnan(lat) == (seen < 0)).all(), "seen_lateral is NaN exactly where unseen")
    s = w.observer_state()
    need(isinstance(s, int | np.integer) and 0 <= s < model.domain.n_states, "observer_state()")
    detections = w.detections()
    need(isinstance(detections, list), "detections() is a list")
    for d in detections:
        need(isinstance(d, Detection) and d.t == w.t and d.robot in sc.robot_names, "a Detection")
    goal = w.at_goal()
    need(isinstance(goal, bool), "at_goal() is a bool")
    extras = w.extras()
    if extras is not None:
        json.dumps(extras.to_dict())  # a run's JSON record takes it
        need(isinstance(extras.truth(), str | None), "extras().truth() is a str or None")
        need(isinstance(extras.damaged(), bool | None), "extras().damaged() is a bool or None")
        notes = extras.notes()
        need(isinstance(notes, tuple) and all(isinstance(n, str) for n in notes),
             "extras().notes() is a tuple of str")  # fmt: skip
    lateral = None if w.seen_lateral is None else w.seen_lateral[-1].tobytes()
    return (w.t, seen.tobytes(), true.tobytes(), lateral, int(s), detections, goal)


def _check_runs(
    cls: World, sc: Scenario, model: ObserverModel, steps: int, seed: int, need
) -> None:
    """Two runs of one setup, L watching and then moving: checked at every step, and equal."""
    runs = []
    actions = [None] * steps + [a % len(ACTIONS) for a in range(steps)]
    for _ in range(2):
        w = cls(_setup(sc, model, seed))
        n_states = sc.domain.n_states
        need(
            isinstance(w.visible, np.ndarray) and w.visible.shape == (n_states,)
            and w.visible.dtype == bool, "visible is an (S,) bool array",
        )  # fmt: skip
        need(w.t == 0, "a new run starts at t = 0")
        need(w.observer_state() == model.start_state, "L starts at its start state")
        record = [_record(w, sc, model, need)]
        for k, action in enumerate(actions):
            truth = w.step(action)
            need(w.t == k + 1, "step() advances t by one")
            need(np.array_equal(truth, w.true[-1]), "step() returns the new true states")
            record.append(_record(w, sc, model, need))
        runs.append(record)
    need(runs[0] == runs[1], "one setup (scenario, seed, L's stream) gives one run")


def _check_patroller_actions(
    cls: World, sc: Scenario, model: ObserverModel, seed: int, need
) -> None:
    w = cls(_setup(sc, model, seed))
    n = len(sc.robots)
    stop = np.full(n, len(ACTIONS) - 1)
    if not cls.takes_patroller_actions:
        try:
            w.step(patroller_actions=stop)
        except NotImplementedError:
            need(w.t == 0 and len(w.true) == 1, "a refused step moves nothing")
            return
        need(False, "takes_patroller_actions is False, yet step(patroller_actions=...) ran")
    for bad in (np.zeros(n + 1, dtype=int), np.full(n, len(ACTIONS))):
        try:
            w.step(patroller_actions=bad)
        except ValueError:
            need(w.t == 0 and len(w.true) == 1, "refused patroller actions move nothing")
        else:
            need(False, f"step(patroller_actions={bad.tolist()}) is refused (ValueError)")
    truth = w.step(0, patroller_actions=stop)
    need(w.t == 1 and np.array_equal(truth, w.true[-1]), "step(patroller_actions=...) steps")
    _record(w, sc, model, need)


def _same_trajectories(a: Trajectories, b: Trajectories) -> bool:
    fields = ("t", "robot", "row", "col", "heading")
    return a.horizon == b.horizon and all(
        np.array_equal(getattr(a, f), getattr(b, f)) for f in fields
    )


def _check_simulate(
    cls: World, sc: Scenario, steps: int, seed: int, need, row: WorldSpec | None
) -> None:
    sims = [cls.simulate(sc, steps, seed=seed, random_starts=True) for _ in range(2)]
    sim = sims[0]
    need(isinstance(sim, Simulation), "simulate() returns a Simulation")
    for what in ("observations", "truth"):
        tr = getattr(sim, what)
        need(isinstance(tr, Trajectories) and tr.horizon == steps, f"simulate().{what} spans steps")
        need(tr.robot_names == sc.robot_names, f"simulate().{what} names the scenario's robots")
    need(len(sim.truth) == steps * len(sc.robots), "simulate().truth has every robot every step")
    need(sim.observability == sc.observability, "simulate() records the scenario's view")
    need(sim.step_seconds is None or sim.step_seconds > 0, "simulate().step_seconds > 0 or None")
    need(all(isinstance(x, str) for x in sim.report), "simulate().report holds lines")
    need(
        all(_same_trajectories(getattr(a, f), getattr(sims[1], f))
            for a in sims[:1] for f in ("observations", "truth")),
        "one seed gives one simulation",
    )  # fmt: skip
    if row is not None:
        need((sim.poses is not None) == row.records_poses, "simulate().poses as records_poses")
    if sim.poses is not None:
        need(sim.poses.true_rate_hz > 0, "simulate().poses.true_rate_hz > 0")
        need(len(sim.poses.observed) == len(sim.observations), "a measured pose per observation")
    full = cls.simulate(sc, 2, seed=seed, observability=1.0)
    need(full.observability == 1.0, "simulate(observability=...) is the view used")


def _check_scenario_methods(cls: World, sc: Scenario, need, row: WorldSpec | None) -> None:
    names = sc.robot_names
    cls.read_section(sc)  # the world's own section reads (ValueError otherwise)
    model = cls.modelled(sc)
    need(isinstance(model, Scenario) and model.robot_names == names, "modelled() keeps robots")
    need(
        all(np.array_equal(model.true_policy(i), sc.true_policy(i)) for i in range(len(names))),
        "modelled() keeps the patrollers' true policies",
    )
    need(isinstance(cls.version(), str), "version() is a str")
    before = cls.damaged_parts(sc)
    need(
        isinstance(before, dict) and tuple(before) == names
        and all(isinstance(p, tuple) and all(isinstance(x, str) for x in p)
                for p in before.values()),
        "damaged_parts() maps every robot to a tuple of part names",
    )  # fmt: skip
    value = row.experiment_damage if row is not None else _DAMAGE
    robot = names[0]
    applied = 0
    for part in sc.feature_map.features:
        try:
            damaged = cls.apply_damage(sc, robot, part, value)
        except ValueError:
            continue  # not a part of this world (physics: only the wheels)
        applied += 1
        need(part in cls.damaged_parts(damaged)[robot], f"apply_damage({part}={value}) damages it")
        healthy = cls.healthy_value(sc, part)
        need(isinstance(healthy, float) and 0.0 < healthy <= 1.0, "healthy_value() is in (0, 1]")
        healed = cls.apply_damage(damaged, robot, part, healthy)
        need(
            part not in cls.damaged_parts(healed)[robot],
            f"apply_damage({part}=healthy_value()) heals it",
        )
    need(applied > 0, "apply_damage() takes some transition feature")
    need(cls.damaged_parts(sc) == before, "apply_damage() leaves the scenario it was given as is")
    first = sc.feature_map.features[0]
    for bad in (("nobody", first, value), (robot, "no-such-part", value), (robot, first, 1.5)):
        try:
            cls.apply_damage(sc, *bad)
        except ValueError:
            continue
        need(False, f"apply_damage{bad} is refused (ValueError)")
