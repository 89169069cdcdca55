"""The sequence likelihood's two gradients: forward mode (derivatives propagated alongside) and
reverse mode (the adjoint of the gap filter) agree with each other, with the first forward-mode
implementation kept in ``tests/sequence_reference.py``, and with finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.learning.irl import IRLProblem, OccludedMaxEntIRL
from mirl.learning.sequence import BlockOperator, ObservedSequence
from mirl.learning.soft_policy import _Dynamics
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario
from tests.references.sequence import forward_mode_loglik


def _case(name: str, seed: int, steps: int = 450, observability: float | None = None):
    """A simulated record of robot 0, its sequence, and a random π and dπ/dθ to test with."""
    sc = load_scenario(name)
    d = sc.domain
    seen = sc.observability if observability is None else observability
    obs = simulate(sc, steps, seed=seed, observability=seen, random_starts=True)
    x = obs.observations.state_series(d, 0)
    if not (x >= 0).any():
        return None  # never seen: nothing to filter
    vis = d.visible_states(seen) | np.isin(np.arange(d.n_states), x[x >= 0])
    dyn = _Dynamics(sc.true_transitions(0), d.n_actions)
    seq = ObservedSequence(x, np.ones(len(x), bool), dyn, d.n_states)
    rng = np.random.default_rng(seed)
    pi = rng.random((d.n_states, d.n_actions)) ** 4  # uneven, as learned policies are
    pi /= pi.sum(axis=1, keepdims=True)
    dpi = rng.normal(size=(d.n_states, d.n_actions, 5))
    dpi -= dpi.mean(axis=1, keepdims=True)
    return seq, dyn, pi, dpi, vis


def _block(dyn, pi, dpi):
    return BlockOperator()(dyn.transposed_policy(pi), dyn.transposed_policy(dpi))


@pytest.mark.parametrize(("name", "seed"), [("boyd2", 0), ("boyd2", 5), ("boydright-3", 1)])
def test_both_gradients_match_the_first_implementation(name, seed):
    seq, dyn, pi, dpi, vis = _case(name, seed)  # type: ignore[misc]
    assert seq._gap_max > 8 and len(seq._gap_steps) > 2  # rescaling and several gaps happen
    B = _block(dyn, pi, dpi)
    ref_ll, ref_g = forward_mode_loglik(seq, pi, B, vis, dpi)
    ll, g = seq.loglik(pi, B, vis, dpi)  # forward mode: bit for bit the first implementation
    assert ll == ref_ll
    assert np.array_equal(g, ref_g)
    PT = dyn.transposed_policy(pi)
    rev_ll, rev_g = seq.loglik_reverse(pi, PT, vis, dpi)
    assert rev_ll == ref_ll  # the value is the same filter
    np.testing.assert_allclose(rev_g, ref_g, rtol=1e-10, atol=1e-10 * np.abs(ref_g).max())
    value, _ = seq.loglik(pi, PT, vis)
    assert value == ref_ll


def test_reverse_gradient_on_the_office():
    seq, dyn, pi, dpi, vis = _case("office", 2, steps=200)
    assert seq._gap_max > 8  # rescaled at least once
    ref_ll, ref_g = forward_mode_loglik(seq, pi, _block(dyn, pi, dpi), vis, dpi)
    ll, g = seq.loglik_reverse(pi, dyn.transposed_policy(pi), vis, dpi)
    assert ll == ref_ll
    np.testing.assert_allclose(g, ref_g, rtol=1e-10, atol=1e-10 * np.abs(ref_g).max())


def test_reverse_gradient_equals_finite_differences():
    """Along a direction δ in π-space, d/dε log L(π + ε δ) = Σ ∂ log L/∂π · δ."""
    seq, dyn, pi, dpi, vis = _case("boyd2", 3, steps=300)
    delta = dpi[:, :, 0]
    eps = 1e-6
    lo, hi = (
        seq.loglik(p, dyn.transposed_policy(p), vis)[0]
        for p in (pi - eps * delta, pi + eps * delta)
    )
    _, g = seq.loglik_reverse(pi, dyn.transposed_policy(pi), vis, dpi[:, :, :1])
    assert g[0] == pytest.approx((hi - lo) / (2 * eps), rel=1e-6)


def test_tails_and_shrinking_columns_are_covered():
    """Views through a random quarter of the states: many exit states, so columns drop out as
    their gaps end, and a record that ends out of view (a tail read)."""
    sc = load_scenario("boyd2")
    d = sc.domain
    rng = np.random.default_rng(7)
    vis = rng.random(d.n_states) < 0.25
    x = simulate(sc, 160, seed=7, observability=1.0).observations.state_series(d, 0)
    x = np.where(vis[np.maximum(x, 0)], x, -1)
    x[-1] = -1
    dyn = _Dynamics(sc.true_transitions(0), d.n_actions)
    seq = ObservedSequence(x, np.ones(len(x), bool), dyn, d.n_states)
    assert (seq._gap_ends < 0).any() and len(set(seq._live[1:])) > 2
    pi = rng.random((d.n_states, d.n_actions)) ** 4
    pi /= pi.sum(axis=1, keepdims=True)
    dpi = rng.normal(size=(d.n_states, d.n_actions, 3))
    vis |= np.isin(np.arange(d.n_states), x[x >= 0])
    ref_ll, ref_g = forward_mode_loglik(seq, pi, _block(dyn, pi, dpi), vis, dpi)
    ll, g = seq.loglik_reverse(pi, dyn.transposed_policy(pi), vis, dpi)
    assert ll == ref_ll
    np.testing.assert_allclose(g, ref_g, rtol=1e-10, atol=1e-10 * np.abs(ref_g).max())


def test_fits_with_either_gradient_reach_the_same_weights():
    sc = load_scenario("boyd2")
    d = sc.domain
    obs = simulate(sc, 300, seed=4, observability=0.14, random_starts=True).observations
    x = obs.state_series(d, 1)
    problem = IRLProblem(
        d.reward_features,
        sc.true_transitions(1),
        discount=sc.discount,
        visible=d.visible_states(0.14),
    )
    forward, reverse = (
        OccludedMaxEntIRL(gradient=mode).fit(problem, x) for mode in ("forward", "reverse")
    )
    np.testing.assert_allclose(reverse.weights_, forward.weights_, rtol=1e-6, atol=1e-6)
    assert np.array_equal(reverse.policy_, forward.policy_)


def test_auto_takes_forward_mode_on_the_small_maps_and_reverse_on_the_office():
    modes = {}
    for name in ("boyd2", "boydright-3", "office"):
        sc = load_scenario(name)
        d = sc.domain
        run = simulate(sc, 300, seed=1, observability=1.0)
        irl = OccludedMaxEntIRL()
        problem = IRLProblem(d.reward_features, sc.true_transitions(0), sc.discount)
        irl._prepare(problem, run.observations.state_series(d, 0), None, None)
        modes[name] = irl._reverse_mode()
    assert modes == {"boyd2": False, "boydright-3": False, "office": True}


def test_auto_falls_back_to_forward_mode_when_the_history_would_not_fit(monkeypatch):
    from mirl.learning import irl as irl_module

    sc = load_scenario("office")
    d = sc.domain
    x = simulate(sc, 200, seed=2, observability=sc.observability).observations.state_series(d, 0)
    irl = OccludedMaxEntIRL()
    problem = IRLProblem(
        d.reward_features, sc.true_transitions(0), sc.discount, visible=d.visible_states(0.14)
    )
    irl._prepare(problem, x, None, None)
    assert irl._sequence.history_size > 0 and irl._reverse_mode()
    monkeypatch.setattr(irl_module, "_HISTORY_BYTES", 16 * irl._sequence.history_size - 1)
    assert not irl._reverse_mode()


def test_unknown_gradient_mode_is_refused():
    with pytest.raises(ValueError, match="unknown gradient 'adjoint'"):
        OccludedMaxEntIRL(gradient="adjoint")


def test_a_robot_seen_on_one_step_only_has_no_observed_move():
    """Found on Willow Garage at 0.5 m (a patroller seen once in 300 steps): on a sparse model
    (more than _DENSE_LIMIT states) no pair of consecutive observations used to fail in scipy's
    empty fancy indexing with "cannot reshape array of size 1 into shape (0,4)"."""
    sc = load_scenario("office")
    d = sc.domain
    dyn = _Dynamics(sc.true_transitions(0), d.n_actions)
    assert dyn.dense is None
    x = np.full(50, -1)
    x[10] = int(np.flatnonzero(d.visible_states(0.14))[0])
    seq = ObservedSequence(x, np.ones(len(x), bool), dyn, d.n_states)
    assert seq._Tab.shape == (0, d.n_actions)
    pi = np.full((d.n_states, d.n_actions), 1.0 / d.n_actions)
    value, _ = seq.loglik(pi, dyn.transposed_policy(pi), d.visible_states(0.14))
    assert np.isfinite(value)
