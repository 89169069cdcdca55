"""Teams of N ≥ 2 patrollers: meetings between any pair in the simulator, the exact N-robot
joint filter against the pair filter and the factored one, equilibrium weighing over pairs and
three-robot learning (the filters' parts: tests/planning/test_team_filter.py; the RL
environments: tests/envs)."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.learning.equilibria import meeting_pairs, weigh_equilibria, weigh_team_equilibria
from mirl.learning.results import oracle_models
from mirl.planning.belief import UNSEEN, BeliefFilter
from mirl.planning.observer import observer_model
from mirl.simulation.grid import PatrolSimulator, simulate
from mirl.world.scenario import load_scenario


@pytest.fixture(scope="module")
def br3():
    return load_scenario("boydright-3")


def test_three_robots_meet_pairwise_and_first_meeting_wins(br3):
    d = br3.domain
    sim = PatrolSimulator(br3)
    sim.reset(seed=0)
    # I and K face each other on the top hallway next to (0, 10); J is far away
    sim.states = np.array(
        [d.state_index(0, 9, 0), d.state_index(13, 16, 1), d.state_index(0, 11, 2)]
    )
    sim.policies = sim.policies.copy()
    sim.policies[:, :] = 0  # everybody drives forward
    acts, met = sim.intended_actions()
    assert met
    # stop/go: I (row player of pair (0, 2)) stops, K goes; J keeps its own action
    assert acts.tolist() == [3, 0, 0]
    # a result over a long run: meetings happen between every pair of the three
    res = simulate(br3, 600, seed=2, random_starts=True)
    assert res.interactions > 0 and res.truth.horizon == 600


def test_exact_team_filter_equals_the_pair_filter():
    """The S^N tensor filter with N = 2 is the pair filter (same meetings, same game)."""
    sc = load_scenario("boyd2")
    learned = oracle_models(sc)
    model = observer_model(sc)
    vis = sc.domain.visible_states(sc.observability)
    pair = BeliefFilter(sc.domain, learned, visible=vis, joint=True)
    team = BeliefFilter(sc.domain, learned, visible=vis, mode="team")  # the tensor code on two
    assert pair.mode == "pair"
    res = simulate(sc, 60, seed=4, random_starts=True)
    seen = np.stack([res.observations.state_series(sc.domain, i) for i in range(2)], axis=1)
    for row in seen:
        pair.update(row)
        team.update(row)
    a, b = pair.predict(15, model), team.predict(15, model)
    np.testing.assert_allclose(a.occupancy, b.occupancy, atol=1e-10)
    np.testing.assert_allclose(a.detection, b.detection, atol=1e-10)


RING = """\
L......
#.###.#
#.#g#.#
#.....#
"""

RING_SCENARIO = """\
name = "ring3"
map = "ring.txt"
observability = 0.3
[reward]
features = [{ name = "moved", kind = "moved" }, { name = "ends", kind = "turn_around" }]
weights = { moved = 1.0, ends = 0.3 }
[[robots]]
start = [0, 1, 0]
[[robots]]
start = [3, 5, 2]
[[robots]]
start = [0, 6, 2]
"""


def test_factored_filter_is_closer_to_exact_than_independent_marginals(tmp_path):
    """Three robots on a small ring (S³ = 262 144 joint states): the factored filter's pairwise
    meeting corrections bring its predicted detection closer to the exact joint's than
    independent marginals (meetings ignored) get."""
    from mirl.planning.team_filter import FactoredTeam, TeamParts

    sc = _ring3(tmp_path)
    learned = oracle_models(sc)
    model = observer_model(sc)
    vis = sc.domain.visible_states(sc.observability)
    exact = BeliefFilter(sc.domain, learned, visible=vis, joint=True)
    fact = BeliefFilter(sc.domain, learned, visible=vis, joint=False)
    indep = BeliefFilter(sc.domain, learned, visible=vis, joint=False)
    parts = TeamParts(sc.domain, learned)
    parts.meet = [m * 0.0 for m in parts.meet]
    indep.form.team = FactoredTeam(parts)
    assert exact.mode == "team" and fact.mode == "factored"
    res = simulate(sc, 30, seed=1, random_starts=True)
    assert res.interactions > 0
    seen = np.stack([res.observations.state_series(sc.domain, i) for i in range(3)], axis=1)
    for row in seen:
        for f in (exact, fact, indep):
            f.update(row)
    a, b, c = (f.predict(12, model) for f in (exact, fact, indep))
    for p in (a, b, c):
        assert p.occupancy.sum(axis=2) == pytest.approx(1.0)
    err_fact = np.abs(a.detection - b.detection).mean()
    err_indep = np.abs(a.detection - c.detection).mean()
    assert err_fact < err_indep


def _ring3(tmp_path):
    (tmp_path / "ring.txt").write_text(RING)
    (tmp_path / "ring3.toml").write_text(RING_SCENARIO)
    return load_scenario(tmp_path / "ring3.toml")


def _reference_filter(sc, learned, vis):
    """A joint filter whose tensor steps are the first implementation's."""
    from mirl.planning.team_filter import TeamParts
    from tests.references.team_filter import ReferenceExactTeam

    f = BeliefFilter(sc.domain, learned, visible=vis, joint=True)
    f.form.team = ReferenceExactTeam(TeamParts(sc.domain, learned))
    return f


def test_exact_team_propagation_equals_the_first_implementation(tmp_path):
    """The sparse meeting chains and rotated mode products give the first version's step: on
    a random joint belief (every meeting assignment populated) and along a filtered run."""
    sc = _ring3(tmp_path)
    learned = oracle_models(sc)
    vis = sc.domain.visible_states(sc.observability)
    new = BeliefFilter(sc.domain, learned, visible=vis, joint=True)
    ref = _reference_filter(sc, learned, vis)
    b = np.random.default_rng(0).random((sc.domain.n_states,) * 3)
    b /= b.sum()
    assert len(new.form.team.meetings.idx) > 0
    new_team, ref_team = new.form.team, ref.form.team
    np.testing.assert_allclose(new_team.propagate(b), ref_team.propagate(b), rtol=1e-12, atol=0)
    np.testing.assert_allclose(new_team.marginals(b), ref_team.marginals(b), rtol=1e-12)
    res = simulate(sc, 25, seed=3, random_starts=True)
    assert res.interactions > 0
    seen = np.stack([res.observations.state_series(sc.domain, i) for i in range(3)], axis=1)
    for row in seen:
        new.update(row)
        ref.update(row)
    np.testing.assert_allclose(new.belief, ref.belief, rtol=1e-10, atol=1e-15)
    model = observer_model(sc)
    a, c = new.predict(10, model), ref.predict(10, model)
    np.testing.assert_allclose(a.detection, c.detection, atol=1e-12)
    np.testing.assert_allclose(a.hazard, c.hazard, atol=1e-12)


def test_exact_team_on_boyd2_with_three_robots_matches_the_first_implementation():
    """boyd2 with a third robot (124³ joint states): a few filtered steps, then predicted
    detection, against the first implementation."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from bench_team import boyd2_three

    sc = boyd2_three()
    learned = oracle_models(sc)
    vis = sc.domain.visible_states(sc.observability)
    new = BeliefFilter(sc.domain, learned, visible=vis, joint=True)
    ref = _reference_filter(sc, learned, vis)
    assert new.mode == "team"
    res = simulate(sc, 6, seed=0, random_starts=True)
    seen = np.stack([res.observations.state_series(sc.domain, i) for i in range(3)], axis=1)
    for row in seen:
        new.update(row)
        ref.update(row)
    model = observer_model(sc)
    a, c = new.predict(4, model), ref.predict(4, model)
    np.testing.assert_allclose(a.occupancy, c.occupancy, atol=1e-13)
    np.testing.assert_allclose(a.detection, c.detection, atol=1e-13)
    assert a.detection.max() > 0.05  # something to compare


def test_default_filter_for_three_on_boyd2_is_factored():
    sc = load_scenario("boydright-3")
    f = BeliefFilter(sc.domain, oracle_models(sc))
    assert f.mode == "factored"  # 184³ joint states exceed max_joint_states
    f.update([UNSEEN] * 3)
    assert f.belief.shape == (3, sc.domain.n_states)


def test_team_weighing_reduces_to_the_pair_for_two():
    sc = load_scenario("boyd2")
    res = simulate(sc, 200, seed=3, random_starts=True)
    series = [res.observations.state_series(sc.domain, i) for i in range(2)]
    pol = [sc.true_policy(i) for i in range(2)]
    T = [sc.true_transitions(i) for i in range(2)]
    vis = sc.domain.visible_states(sc.observability)
    cands = sc.game.equilibria()
    pair = weigh_equilibria(sc.domain, series, pol, T, cands, vis)
    team = weigh_team_equilibria(sc.domain, series, pol, T, cands, vis)
    np.testing.assert_array_equal(pair.log_likelihoods, team.shared.log_likelihoods)
    assert list(team.pairs) == [(0, 1)]


def test_meeting_pairs_lists_pairs_seen_together(br3):
    res = simulate(br3, 300, seed=0, observability=1.0, random_starts=True)
    series = [res.observations.state_series(br3.domain, i) for i in range(3)]
    pairs = meeting_pairs(br3.domain, series)
    assert set(pairs) <= {(0, 1), (0, 2), (1, 2)} and len(pairs) >= 2


def test_damage_any_robot(br3):
    hurt = br3.with_damage("K", "right_wheel", 0.6)
    assert hurt.robots[2].feature_probabilities["right_wheel"] == 0.6
    assert br3.robots[2].feature_probabilities["right_wheel"] == 0.95


def test_learn_prints_each_pair_of_a_team(tmp_path, capsys):
    """`mirl learn` on a team gives, besides the team's equilibrium, each pair L weighed."""
    from mirl.cli import main

    obs = tmp_path / "br3.csv"
    argv = ["simulate", "--scenario", "boydright-3", "--steps", "400", "--seed", "2"]
    assert main([*argv, "--observations", str(obs)]) == 0
    capsys.readouterr()
    assert main(["learn", "--scenario", "boydright-3", "--observations", str(obs)]) == 0
    lines = capsys.readouterr().out.splitlines()
    (pairs,) = [x for x in lines if x.startswith("pairs ")]
    assert "I/J " in pairs and "(other pairs: the equilibrium above)" in pairs


def test_a_team_seen_meeting_nowhere_names_no_pair(br3):
    """With no pair of a team seen meeting, the first pair is weighed on what L did not see
    (``meeting_pairs``' fallback), and no pair is reported as learned on its own: every pair plays
    the team's equilibrium, which is that pair's."""
    res = simulate(br3, 200, seed=0, observability=1.0, random_starts=True)
    unseen = np.full(res.truth.horizon, UNSEEN)
    series = [res.observations.state_series(br3.domain, 0), unseen, unseen]
    assert meeting_pairs(br3.domain, series, fallback=False) == []
    assert meeting_pairs(br3.domain, series) == [(0, 1)]
    d = br3.domain
    pol = [br3.true_policy(i) for i in range(3)]
    T = [br3.true_transitions(i) for i in range(3)]
    vis = d.visible_states(br3.observability)
    team = weigh_team_equilibria(d, series, pol, T, br3.game.equilibria(), vis)
    assert not team.seen_meeting and list(team.pairs) == [(0, 1)]
    assert team.best_per_pair() == {}
    assert team.shared is team.pairs[(0, 1)]
    met = [res.observations.state_series(d, i) for i in range(3)]
    assert weigh_team_equilibria(d, met, pol, T, br3.game.equilibria(), vis).best_per_pair()


def test_learn_says_when_no_pair_of_a_team_was_seen_meeting(tmp_path, capsys):
    """`mirl learn` on a team of whom L saw one robot names no pair as learned on its own."""
    from mirl.cli import main

    obs = tmp_path / "br3.csv"
    argv = ["simulate", "--scenario", "boydright-3", "--steps", "200", "--seed", "2"]
    assert main([*argv, "--observations", str(obs)]) == 0
    only_i = tmp_path / "br3-I.csv"
    rows = obs.read_text().splitlines()
    only_i.write_text("\n".join(r for r in rows if ",J," not in r and ",K," not in r) + "\n")
    capsys.readouterr()
    assert main(["learn", "--scenario", "boydright-3", "--observations", str(only_i)]) == 0
    lines = capsys.readouterr().out.splitlines()
    (pairs,) = [x for x in lines if x.startswith("pairs ")]
    assert "none seen meeting" in pairs
