"""The two halves of a run after learning, on a scripted world: L waits and re-plans at the
moments the module names (the step a round asked for, a patroller leaving view, a re-learn) and
goes at its go time or gives up at the deadline; then follows its plan, re-planning when it
outlives it, until it is seen, arrives or runs out of steps."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mirl.experiments.execution import (
    Decision,
    PlanFollower,
    execute,
    propagate_blind,
    wait_for_go,
)
from mirl.experiments.records import Detection, PlanAttempt
from mirl.planning.belief import NOT_WATCHING

UNSEEN = -1


class ScriptedWorld:
    """A world whose sightings, detections and goal are scripted per step."""

    def __init__(self, sightings, detected_at=None, goal_at=None):
        self.script = [np.asarray(s) for s in sightings]
        self.t = 0
        self.seen = [self.script[0]]
        self.moves: list[int | None] = []
        self.detected_at, self.goal_at = detected_at, goal_at

    def step(self, observer_action=None, *, patroller_actions=None):
        self.t += 1
        self.seen.append(self.script[min(self.t, len(self.script) - 1)])
        self.moves.append(observer_action)

    def observer_state(self):
        return self.t % 3

    def detections(self):
        if self.t == self.detected_at:
            return [Detection(self.t, "I", (0, 0, 0), (1, 1))]
        return []

    def at_goal(self):
        return self.t == self.goal_at


def plan(t0=0, horizon=100):
    return SimpleNamespace(t0=t0, horizon=horizon, policy=np.zeros((horizon, 3), int))


class Rounds:
    """A go rule that goes ``go_in`` steps after its ``go_on``-th round, else asks again in
    ``every`` steps; it records when it was asked."""

    def __init__(self, world, go_in=None, go_on=1, every=50):
        self.world, self.go_in, self.go_on, self.every = world, go_in, go_on, every
        self.asked: list[int] = []

    def __call__(self):
        t = self.world.t
        self.asked.append(t)
        go = t + self.go_in if self.go_in is not None and len(self.asked) >= self.go_on else None
        return Decision(plan(t), go, t + self.every, PlanAttempt(t, 0.5, go))


def timings():
    return {"plan": 0.0, "observe": 0.0}


def test_l_goes_at_the_go_time_of_its_round():
    world = ScriptedWorld([[0, 0]])
    decide = Rounds(world, go_in=3)
    spent = timings()
    chosen, go_time, attempts = wait_for_go(world, decide, lambda: False, 100, False, spent)
    assert (go_time, world.t, decide.asked) == (3, 3, [0])
    assert chosen.t0 == 0 and [a.go_time for a in attempts] == [3]
    assert spent["plan"] > 0 and spent["observe"] > 0


def test_rounds_come_when_asked_for_and_at_the_deadline_l_gives_up():
    world = ScriptedWorld([[0, 0]])
    decide = Rounds(world, every=4)
    _, go_time, attempts = wait_for_go(world, decide, lambda: False, 10, False, timings())
    assert go_time is None and world.t == 10
    assert decide.asked == [0, 4, 8] and len(attempts) == 3


def test_a_patroller_leaving_view_calls_a_round_unless_a_go_time_is_committed():
    sightings = [[0, 5], [0, 5], [0, UNSEEN], [0, UNSEEN]]  # J leaves L's view at t = 2
    for commit, asked in ((False, [0, 2]), (True, [0])):
        world = ScriptedWorld(sightings)
        decide = Rounds(world, go_in=4)
        _, go_time, _ = wait_for_go(world, decide, lambda: False, 100, commit, timings())
        assert decide.asked == asked
        assert go_time == asked[-1] + 4


def test_a_re_learn_calls_a_round_while_l_has_no_go_time():
    world = ScriptedWorld([[0, 0]])
    decide = Rounds(world, go_in=2, go_on=2)  # goes from its second round on
    relearned_at = {3}
    _, go_time, _ = wait_for_go(
        world, decide, lambda: world.t in relearned_at, 100, False, timings()
    )
    assert decide.asked == [0, 3] and go_time == 5


def follower():
    return PlanFollower(lambda k, s: 7, plan(horizon=100), None, 0)


@pytest.mark.parametrize(
    "detected_at, goal_at, outcome, steps",
    [(13, None, "detected", 3), (None, 12, "success", 2), (None, None, "timeout", 5)],
)
def test_l_follows_its_plan_until_seen_arrived_or_out_of_steps(
    detected_at, goal_at, outcome, steps
):
    world = ScriptedWorld([[0, 0]], detected_at=detected_at, goal_at=goal_at)
    world.t = 10  # L goes at t = 10
    states = np.array([(r, r + 1, r % 4) for r in range(3)])
    model = SimpleNamespace(domain=SimpleNamespace(states=states), start_state=1)
    got, path, detections = execute(world, model, follower(), None, 5)
    assert got == outcome and world.t == 10 + steps
    assert path[0] == (10, 1, 2, 1)  # where L starts, at its go time
    assert [p[0] for p in path] == list(range(10, 11 + steps))
    assert path[1:] == [(t, *states[t % 3]) for t in range(11, 11 + steps)]
    assert world.moves == [7] * steps
    assert [d.t for d in detections] == ([13] if outcome == "detected" else [])


def test_a_follower_outliving_its_plan_re_plans_and_follows_the_new_one():
    replans: list[bool] = []
    f = PlanFollower(lambda k, s: 5, plan(t0=0, horizon=3), None, 1)
    f.replan = lambda: (replans.append(True), plan(horizon=2))[1]
    first = [f.action(0) for _ in range(2)]  # steps 1 and 2 of a 3-step plan
    assert first == [5, 5] and replans == []
    assert f.action(0) == 0 and replans == [True]  # the new plan's policy (zeros)
    assert f.k == 1 and f.plan.horizon == 2


def test_the_belief_is_advanced_without_evidence():
    updates = []

    class Belief:
        t, n_robots = 4, 2

        def update(self, seen):
            updates.append(seen.tolist())
            self.t += 1

    belief = Belief()
    propagate_blind(belief, 7)
    assert belief.t == 7 and updates == [[NOT_WATCHING] * 2] * 3
    propagate_blind(None, 9)  # no belief kept: nothing to do
    propagate_blind(belief, 5)  # already past: nothing
    assert belief.t == 7
