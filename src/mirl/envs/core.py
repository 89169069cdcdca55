"""One episode of a world as both environments see it (:class:`Episode`): a world of
:data:`mirl.worlds.WORLDS` stepped through its contract, with what an agent observes of it.

The world does all the stepping — the patrollers' moves, L's failures, detection and the goal —
exactly as in a run of :func:`~mirl.experiments.episode.run_episode`; an episode only seeds it,
remembers whether L has left its start cell, and reads L's view. One seed fixes an episode: it
is split into the world's seed and L's failure stream (independent streams).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mirl._validation import Interval, check_argument
from mirl.planning.observer import ObserverModel
from mirl.world.scenario import Scenario
from mirl.worlds import RunSetup, RunWorld, World

__all__ = ["Episode", "check_episode_settings"]


def check_episode_settings(
    length_name: str, length: Any, observability: Any = None, **rewards: Any
) -> None:
    """Refuse an episode length, a view or a reward the environments could only truncate or
    propagate.

    A fractional length would be cut, one below 1 would end every episode at its first step,
    a view outside [0, 1] was refused only by the first ``reset`` (and ``"0.5"`` taken as a
    number), and a NaN or infinite reward would reach every learner's returns. Both
    environments check their constructors' arguments here.

    Parameters
    ----------
    length_name : str
        The length argument's name (``max_steps``, ``max_cycles``), for the message.
    length : int
        Steps after which an episode is truncated: an integer, at least 1.
    observability : float, optional
        The share of the hallway L sees: a number in [0, 1], or None (the scenario's).
    **rewards : float
        Each reward argument by name: a finite number.

    Raises
    ------
    OptionError
        One of them is not what it must be; the message names it.
    """
    check_argument(length_name, length, Interval(int, 1, None))
    check_argument("observability", observability, Interval(float, 0.0, 1.0), None)
    for name, value in rewards.items():
        check_argument(name, value, Interval(float))


class Episode:
    """A new world for one episode, seeded by ``seed``.

    Parameters
    ----------
    world_class : World
        The world's class, from its row of :data:`~mirl.worlds.WORLDS`.
    scenario : Scenario
        The patrollers, their true models and L's map.
    model : ObserverModel
        L's model (its start, goal, moves and failure probability).
    observability : float
        The degree of L's view from its room.
    seed : int
        Fixes the episode.
    """

    def __init__(
        self,
        world_class: World,
        scenario: Scenario,
        model: ObserverModel,
        observability: float,
        seed: int,
    ) -> None:
        world_seq, observer_seq = np.random.SeedSequence(seed).spawn(2)
        setup = RunSetup(
            scenario, model, observability, int(world_seq.generate_state(1)[0]), observer_seq
        )
        self.world: RunWorld = world_class(setup)
        self.scenario, self.model = scenario, model
        self._start_cell = int(model.cell_of(model.start_state))
        self.out = False  # L has left its start cell (and sees nothing from then on)
        self.detected = False
        self.arrived = False

    @property
    def patroller_states(self) -> np.ndarray:
        """(N,) the patrollers' true state indices now."""
        return self.world.true[-1].copy()

    def step(self, observer_action: int, patroller_actions: np.ndarray | None = None) -> None:
        """L takes ``observer_action`` and the patrollers move.

        Then it records whether a patroller saw L, or else L arrived.

        Parameters
        ----------
        observer_action : int
            L's action, an index into :data:`~mirl.world.actions.ACTIONS`.
        patroller_actions : ndarray of int, shape (N,), optional
            The patrollers' actions; by their policies if None.
        """
        self.world.step(observer_action, patroller_actions=patroller_actions)
        cell = int(self.model.cell_of(self.world.observer_state()))
        self.out = self.out or cell != self._start_cell
        self.detected = bool(self.world.detections())
        self.arrived = not self.detected and self.world.at_goal()

    @property
    def outcome(self) -> str | None:
        """``"detected"``, ``"success"`` or None (the episode goes on)."""
        return "detected" if self.detected else ("success" if self.arrived else None)

    def observer_view(self) -> dict[str, Any]:
        """L's observation.

        Returns
        -------
        dict
            ``patrollers`` (N, 3): the (row, col, heading) of each patroller L sees from its
            room (−1 rows for the rest, and for all once L is out); ``observer``: L's own (row,
            col, heading); ``out``: 1 once L has left its start cell.
        """
        patrollers = np.full((len(self.scenario.robots), 3), -1, dtype=np.int64)
        seen = self.world.seen[-1]
        if not self.out:
            mask = seen >= 0
            patrollers[mask] = self.scenario.domain.states[seen[mask]]
        observer = self.model.domain.states[self.world.observer_state()].astype(np.int64)
        return {"patrollers": patrollers, "observer": observer, "out": int(self.out)}
