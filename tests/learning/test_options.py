"""LearnOptions: what learn() takes beyond the record, the scenario and the method, each option
declared once; the sources of models are rows of tables every learning method's row finds."""

from __future__ import annotations

import pytest

from mirl._validation import OptionError
from mirl.learning.learn import REWARD_BUILDERS, TRANSITION_BUILDERS, learn
from mirl.learning.methods import LEARNING_METHODS, METHODS, TRANSITION_SOURCES
from mirl.learning.options import (
    DEFAULT_P,
    EM_INITS,
    IRL_OBJECTIVES,
    IRL_OPTIMIZERS,
    LearnOptions,
)
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario


def test_defaults_resolve_to_what_learning_uses():
    o = LearnOptions()
    assert o.p is None and o.fixed_p == DEFAULT_P == 0.9
    assert o.em_init is None and o.initial_transitions == "intended" == EM_INITS.names[0]
    assert o.restarts == 1 and LearnOptions(optimizer="nelder-mead").restarts == 3
    assert LearnOptions(n_restarts=5).restarts == 5
    assert (o.max_iterations, o.label_tol) == (5, 0.01)
    assert (o.objective, o.optimizer) == ("sequence", "lbfgs")


@pytest.mark.parametrize(
    ("values", "needle"),
    [
        ({"p": -0.1}, "`p` must be a number in [0, 1] or None"),
        ({"max_iterations": 101}, "`max_iterations` must be an integer in [1, 100]"),
        ({"label_tol": 2}, "`label_tol` must be a number in [0, 1]"),
        ({"objective": "count"}, "did you mean 'counts'"),
        ({"optimizer": "bfgs"}, "did you mean 'lbfgs'"),
        ({"n_restarts": 0}, "`n_restarts` must be an integer >= 1 or None"),
        ({"irl_options": ["l2"]}, "`irl_options` must be a mapping"),
        ({"em_init": "zeros"}, "`em_init`: unknown EM initialisation 'zeros' (known: intended,"),
        ({"em_init": 3}, "`em_init` must be one of intended, uniform or None, got 3"),
        ({"maxiter": 3}, "`maxiter` is not an option of LearnOptions"),
    ],
)
def test_bad_options_are_refused_by_name(values, needle):
    with pytest.raises(OptionError) as info:
        LearnOptions(**values)
    assert needle in str(info.value)


def test_an_option_that_changes_nothing_for_the_method_is_refused():
    for name, value, users in (("p", 0.8, "uses_p"), ("em_init", "uniform", "uses_em_init")):
        for method in METHODS.values():
            options = LearnOptions(**{name: value})
            if getattr(method, users):
                options.check_method(method)
            else:
                with pytest.raises(OptionError, match=f"`{name}` applies to the method"):
                    options.check_method(method.name)


def test_an_option_set_away_from_its_default_for_a_method_that_never_reads_it_is_refused():
    """The relabelling's limits (mirl-t alone) and the IRL's options (a learned reward) as p
    and em_init: set for a method without them, refused; at their defaults, or listed as not
    given by the command line, not."""
    sc = load_scenario("boyd2")
    obs = simulate(sc, 30, seed=1, observability=0.14).observations
    for method, values in (
        ("known-r", {"max_iterations": 2}),
        ("known-r", {"objective": "counts"}),
        ("known-r-t", {"optimizer": "nelder-mead"}),
        ("known-r-t", {"label_tol": 0.5}),
        ("mirl", {"max_iterations": 2}),
        ("dbn-em", {"label_tol": 0.5}),
    ):
        (name,) = values
        with pytest.raises(OptionError, match=f"`{name}` applies to the method"):
            learn(obs, sc, method, options=values, score=False)
        LearnOptions(**values).check_method("mirl-t")
        LearnOptions(**values).check_method(method, given=[])  # the flags given: none
    LearnOptions(max_iterations=5, objective="sequence").check_method("known-r")  # defaults
    with pytest.raises(OptionError, match="`objective` applies to the methods mirl-t, mirl and"):
        LearnOptions().check_method("known-r", given=["objective"])  # given, at its default


def test_the_irl_options_are_kept_as_given():
    given = {"l2": 1e-3}
    o = LearnOptions(irl_options=given)
    given["l2"] = 1.0  # the caller's dict changes; the options do not
    assert dict(o.irl_options) == {"l2": 1e-3}
    with pytest.raises(TypeError):
        o.irl_options["l2"] = 2.0  # type: ignore[index]


@pytest.mark.parametrize(
    ("irl_options", "needle"),
    [
        ({"objective": "counts"}, "`irl_options` may not set 'objective', an option of Learn"),
        ({"n_restarts": 3}, "may not set 'n_restarts'"),
        ({"random_state": 1}, "may not set 'random_state': learn()'s own random_state"),
        ({"anchr": "first"}, "unknown estimator option 'anchr' (did you mean 'anchor'?"),
        ({"max_evaluations": 10.5}, "estimator refuses: max_evaluations must be an integer"),
        ({"l2": -1}, "estimator refuses: l2 must be at least 0, got -1"),
    ],
)
def test_irl_options_are_checked_when_the_options_are_made(irl_options, needle):
    """``objective`` in irl_options silently overrode ``objective=``; an unknown keyword or a
    second ``random_state`` was a TypeError from the estimator's call once learning had
    started, and ``max_evaluations=10.5`` ran. Each is one OptionError naming irl_options."""
    with pytest.raises(OptionError) as info:
        LearnOptions(objective="likelihood", irl_options=irl_options)
    assert needle in str(info.value)
    assert LearnOptions(irl_options={"anchor": "reentry", "l2": 0.0}).irl_options["l2"] == 0.0


def test_the_vocabularies_are_tables():
    assert set(IRL_OBJECTIVES) == {"counts", "likelihood", "both", "sequence"}
    assert set(IRL_OPTIMIZERS) == {"nelder-mead", "lbfgs"}
    with pytest.raises(KeyError, match="did you mean 'lbfgs'"):
        IRL_OPTIMIZERS["lbgfs"]


def test_every_source_learn_builds_has_a_builder():
    """A method's row names its sources; learn() has a builder for each it builds (the truth
    aside: it returns that whole), and no builder of a source no table holds."""
    for name in LEARNING_METHODS:
        row = METHODS[name]
        if row.learns:
            assert row.reward in REWARD_BUILDERS and row.transitions in TRANSITION_BUILDERS
    built = {s.name for s in TRANSITION_SOURCES.values() if s.built}
    assert set(TRANSITION_BUILDERS) == built
    assert REWARD_BUILDERS["learned"].labelled and not REWARD_BUILDERS["true"].labelled
    assert TRANSITION_BUILDERS["features"].labelled


def test_labels_by_truth_is_what_learn_does():
    """The methods whose learning reads the true policies (``--damage``'s truth) are those
    whose first labels are the true policies' and whose models are learned from labels."""
    from mirl.learning.learn import _true_policy_labels

    for row in METHODS.values():
        if row.learns:
            reward, motion = REWARD_BUILDERS[row.reward], TRANSITION_BUILDERS[row.transitions]
            by_truth = reward.first_labels is _true_policy_labels
            assert row.labels_by_truth == (by_truth and (reward.labelled or motion.labelled))


def test_learn_takes_options_or_a_mapping_the_same():
    sc = load_scenario("boyd2")
    obs = simulate(sc, 60, seed=1, observability=0.14).observations
    a = learn(obs, sc, "mirl", options=LearnOptions(p=0.8, n_restarts=2), score=False)
    b = learn(obs, sc, "mirl", options={"p": 0.8, "n_restarts": 2}, score=False)
    assert "p=0.8" in a.message and a.message == b.message
    for x, y in zip(a.robots, b.robots, strict=True):
        assert (x.weights == y.weights).all() and (x.policy == y.policy).all()
    with pytest.raises(OptionError, match="`p` applies to the methods mirl and known-r only"):
        learn(obs, sc, "mirl-t", options={"p": 0.8})


def test_options_given_at_their_defaults_learn_as_the_defaults_do():
    from mirl.learning.options import DEFAULT_P, LearnOptions

    assert LearnOptions().in_effect_default
    assert LearnOptions(p=DEFAULT_P, em_init="intended", n_restarts=1).in_effect_default
    for other in ({"p": 0.7}, {"em_init": "uniform"}, {"max_iterations": 3},
                  {"objective": "counts"}, {"n_restarts": 3}):  # fmt: skip
        assert not LearnOptions(**other).in_effect_default, other
