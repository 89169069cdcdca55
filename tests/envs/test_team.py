"""``TeamEnv``: PettingZoo's parallel API test, refused input, every step equal to the
environments' first implementation (tests/references/penetration_env.py), and a world whose
patrollers take no actions refused."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pettingzoo")

from pettingzoo.test import parallel_api_test  # noqa: E402

from mirl.envs import TeamEnv  # noqa: E402
from mirl.world.scenario import load_scenario  # noqa: E402
from tests.envs.test_penetration import _same  # noqa: E402
from tests.references.penetration_env import team_episode  # noqa: E402


def test_passes_the_parallel_api_test():
    env = TeamEnv("boydright-3", max_cycles=40)
    parallel_api_test(env, num_cycles=50)
    assert env.possible_agents == ["I", "J", "K", "L"]


@pytest.mark.parametrize("scenario", ["boyd2", "boydright-3"])
def test_every_step_is_the_first_implementations(scenario):
    sc = load_scenario(scenario)
    env = TeamEnv(sc, max_cycles=80)
    for seed in range(6):
        rng = np.random.default_rng(seed)
        joint = [
            {**{n: int(rng.integers(4)) for n in sc.robot_names}, "L": int(rng.integers(4))}
            for _ in range(80)
        ]
        expected = team_episode(sc, seed, joint, max_cycles=80)
        obs, _ = env.reset(seed=seed)
        got = [obs]
        for actions in joint:
            got.append(env.step(actions))
            if not env.agents:
                break
        assert len(got) == len(expected)
        for step, (g, e) in enumerate(zip(got, expected, strict=True)):
            assert _same(g, e), (seed, step)


def test_refuses_what_it_would_otherwise_default_or_drop():
    env = TeamEnv("boyd2")
    with pytest.raises(ValueError, match="reset"):
        env.step({"I": 0, "J": 0, "L": 0})
    env.reset(seed=0)
    good = {"I": 0, "J": 3, "L": 3}
    for actions, needle in [
        (good | {"X": 0}, r"unknown \['X'\]"),
        ({"I": 0, "L": 3}, r"missing \['J'\]"),
        (good | {"J": 99}, "agent J: action 99"),
        (good | {"L": -1}, "agent L: action -1"),
    ]:
        with pytest.raises(ValueError, match=needle):
            env.step(actions)
    for not_a_dict in (None, [0, 3, 3], 0):
        with pytest.raises(TypeError, match="actions must be a dict of agent to action"):
            env.step(not_a_dict)
    obs, *_ = env.step(good)  # nothing refused above moved anyone
    fresh = TeamEnv("boyd2")
    fresh.reset(seed=0)
    expected, *_ = fresh.step(good)
    for name in ("I", "J"):
        np.testing.assert_array_equal(obs[name], expected[name])
    np.testing.assert_array_equal(obs["L"]["observer"], expected["L"]["observer"])


@pytest.mark.parametrize("seed", [-1, 1.5, "3", True])
def test_a_seed_that_is_no_seed_is_refused_by_name(seed):
    """``reset(seed=1.5)`` ran seed 1 and ``"3"`` seed 3; ``-1`` failed inside numpy
    ("expected non-negative integer"). PenetrationEnv's gymnasium refuses them too."""
    env = TeamEnv("boyd2")
    with pytest.raises(ValueError, match=r"`seed` must be an integer in \[0, 2\^63 - 1\]"):
        env.reset(seed=seed)
    assert env.agents == []  # nothing started
    a, _ = env.reset(seed=np.int64(3))
    b, _ = TeamEnv("boyd2").reset(seed=3)
    np.testing.assert_array_equal(a["I"], b["I"])


def test_a_world_whose_patrollers_take_no_actions_is_refused():
    pytest.importorskip("mujoco")
    with pytest.raises(ValueError, match="world 'physics': its patrollers drive by their own"):
        TeamEnv("boyd2", world="physics")


def test_unknown_agents_are_refused_by_name():
    env = TeamEnv("boyd2")
    assert env.render_mode is None  # PettingZoo reads it
    for space in (env.observation_space, env.action_space):
        with pytest.raises(KeyError, match="no agent 'X': the agents are I, J, L"):
            space("X")
