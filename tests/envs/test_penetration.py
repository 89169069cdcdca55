"""``PenetrationEnv``: gymnasium's checker, seeding, the end of an episode, refused input, and
every step equal to the environments' first implementation (tests/references/penetration_env.py),
which stepped a world of its own."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("gymnasium")

from gymnasium.error import ResetNeeded  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402

from mirl.envs import PenetrationEnv  # noqa: E402
from mirl.planning.observer import observer_model, shortest_path_policy  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402
from tests.references.penetration_env import penetration_episode  # noqa: E402


def _same(a, b) -> bool:
    """Equal observations, infos and rewards, arrays compared by value and dtype."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and np.array_equal(a, b)
    if isinstance(a, tuple):
        return isinstance(b, tuple) and len(a) == len(b) and all(map(_same, a, b))
    return type(a) is type(b) and a == b


def test_passes_gymnasiums_checker_and_a_seed_fixes_the_start():
    env = PenetrationEnv("boyd2", max_steps=200)
    check_env(env, skip_render_check=True)
    a, _ = env.reset(seed=5)
    b, _ = env.reset(seed=5)
    np.testing.assert_array_equal(a["patrollers"], b["patrollers"])


@pytest.mark.parametrize("scenario", ["boyd2", "boydright-3"])
def test_every_step_is_the_first_implementations(scenario):
    """Observations, rewards, ends and infos equal the reference's, step by step, over seeds
    whose episodes end by detection, by success and by truncation."""
    sc = load_scenario(scenario)
    model = observer_model(sc)
    path = shortest_path_policy(model)
    env = PenetrationEnv(sc, max_steps=150)
    outcomes = set()
    for seed in range(8):
        wait = 40 * seed  # L watches from its room (past the episode's end: truncated), then goes

        def policy(t: int, observation: dict, wait: int = wait) -> int:
            state = model.domain.state_index(*observation["observer"])
            return 3 if t < wait else int(path[state])

        expected = penetration_episode(sc, seed, policy, max_steps=150)
        got = [env.reset(seed=seed)]
        while not (len(got) > 1 and (got[-1][2] or got[-1][3])):
            got.append(env.step(policy(len(got) - 1, got[-1][0])))
        assert len(got) == len(expected)
        for step, (g, e) in enumerate(zip(got, expected, strict=True)):
            assert _same(g, e), (seed, step)
        outcomes.add(got[-1][4]["outcome"] if got[-1][2] else "truncated")
    assert len(outcomes) == 3, outcomes  # the comparison saw every way to end


def test_episodes_end_with_goal_or_detection():
    env = PenetrationEnv("boyd2", max_steps=300)
    for seed in range(3):
        env.reset(seed=seed)
        env.action_space.seed(seed)
        while True:
            _, reward, term, trunc, info = env.step(env.action_space.sample())
            if term or trunc:
                break
        assert info["outcome"] in ("detected", "success", None)
        assert reward == {"detected": -1.0, "success": 1.0, None: 0.0}[info["outcome"]]


def test_refuses_what_it_would_otherwise_default_or_drop():
    with pytest.raises(ResetNeeded, match="reset"):
        PenetrationEnv("boyd2").step(0)
    env = PenetrationEnv("boyd2")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="not in Discrete"):
        env.step(4)
    with pytest.raises(ValueError, match="max_steps"):
        PenetrationEnv("boyd2", max_steps=0)
    with pytest.raises(ValueError, match="did you mean 'grid'"):
        PenetrationEnv("boyd2", world="gird")


@pytest.mark.parametrize(("seed", "max_steps", "actions"), [(0, 3, [3] * 3), (0, 300, [0] * 300)])
def test_a_step_after_the_episode_ended_asks_for_reset(seed, max_steps, actions):
    """After truncation (L waits 3 steps) or termination (L walks out at once), a step would
    move the world on and recompute L's outcome; it is refused until the next reset."""
    env = PenetrationEnv("boyd2", max_steps=max_steps)
    env.reset(seed=seed)
    for action in actions:
        *_, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
    assert terminated or truncated
    t = env.episode.world.t
    with pytest.raises(ResetNeeded, match="ended"):
        env.step(3)
    assert env.episode.world.t == t
    env.reset(seed=seed)
    env.step(3)  # a new episode steps again


def test_steps_the_physics_world_through_the_same_contract():
    pytest.importorskip("mujoco")
    env = PenetrationEnv("boyd2", world="physics", max_steps=3)
    obs, info = env.reset(seed=1)
    assert env.observation_space.contains(obs)
    for _ in range(3):
        obs, reward, term, trunc, info = env.step(3)  # L waits in its room
        assert env.observation_space.contains(obs) and reward == 0.0 and not term
    assert trunc and info["t"] == 3 and info["patroller_states"].shape == (2,)
