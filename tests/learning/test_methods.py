"""The table of methods: its rows, what each row implies, and rows that could not run refused
where the table is defined."""

from __future__ import annotations

from dataclasses import replace

import pytest

from mirl._registry import Registry, UnknownNameError
from mirl.learning.methods import (
    LEARNING_METHODS,
    METHODS,
    REWARD_SOURCES,
    TRANSITION_SOURCES,
    Method,
    check_method,
    get_method,
    ruled_options,
    unread_option,
)


def test_the_paper_s_methods_in_its_order_with_the_oracle_last():
    assert METHODS.names == ("mirl-t", "mirl", "known-r-t", "known-r", "dbn-em", "random", "oracle")
    assert [m.paper_name for m in METHODS.values()] == [
        "mIRL*/T+Int", "mIRL*+Int", "Known R/T", "Known R", "DBN-EM", "Random", "Oracle"
    ]  # fmt: skip
    assert LEARNING_METHODS == tuple(n for n in METHODS if n != "random")


def test_what_each_row_implies():
    implied = {
        m.name: (m.uses_p, m.uses_em_init, m.learns, m.has_feature_probabilities)
        for m in METHODS.values()
    }
    assert implied == {
        "mirl-t": (False, False, True, True),
        "mirl": (True, False, True, False),
        "known-r-t": (False, False, True, True),
        "known-r": (True, False, True, False),
        "dbn-em": (False, True, True, False),
        "random": (False, False, False, False),
        "oracle": (False, False, False, True),
    }
    # an option applies to exactly the methods whose transition source reads it
    for option in ("p", "em_init"):
        readers = {s.name for s in TRANSITION_SOURCES.values() if option in s.options}
        assert len(readers) == 1


def test_which_methods_read_which_options():
    """Read off learn() and run_episode: the IRL's options for a learned reward, the
    relabelling's for mirl-t alone, the go rule for a method that plans, re-learning for one
    that learns; every other option applies to every method."""
    readers = {
        option: {m for m in METHODS if unread_option(m, [option]) is None}
        for option in sorted(ruled_options())
    }
    irl = {"mirl-t", "mirl", "dbn-em"}
    assert readers == {
        "em_init": {"dbn-em"},
        "go_rule": set(METHODS) - {"random"},
        "irl_options": irl,
        "label_tol": {"mirl-t"},
        "max_iterations": {"mirl-t"},
        "n_restarts": irl,
        "objective": irl,
        "optimizer": irl,
        "p": {"mirl", "known-r"},
        "relearn": set(LEARNING_METHODS) - {"oracle"},
    }
    assert unread_option("known-r", ["obs_steps", "seed"]) is None  # ruled nowhere
    assert {m for m in METHODS if METHODS[m].labels_by_truth} == {"known-r-t"}


def test_the_refusal_names_the_readers_and_why():
    assert unread_option("known-r", ["max_iterations"]) == (
        "max_iterations",
        "applies to the method mirl-t only, not known-r (it does not relabel the observed steps)",
    )
    option, problem = unread_option("known-r-t", ["p", "objective"])
    assert option == "p" and problem.startswith("applies to the methods mirl and known-r only, ")


def test_every_row_of_the_table_passes_its_check():
    for row in METHODS.values():
        check_method(row)  # raises otherwise
        assert row.reward in REWARD_SOURCES and row.transitions in TRANSITION_SOURCES


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"relabels": True, "transitions": "em"}, "relabelling learns the reward by IRL"),
        ({"relabels": True, "reward": "true"}, "relabelling learns the reward by IRL"),
        ({"relabels": True, "transitions": "fixed-p"}, "relabelling learns the reward by IRL"),
        ({"reward": "learned", "transitions": "true"}, "comes with the true reward"),
        ({"plans": False}, "does not plan has no models"),
        ({"reward": "none"}, "plans needs a reward and a transition model"),
        ({"transitions": "none"}, "plans needs a reward and a transition model"),
        ({"transitions": "featurs"}, "did you mean 'features'"),
        ({"reward": "truth"}, "unknown reward source 'truth'"),
    ],
)
def test_a_row_that_cannot_run_is_refused_where_it_is_defined(change, message):
    good = METHODS["mirl"]
    with pytest.raises(ValueError, match=message) as e:
        Registry("method", [replace(good, name="new", **change)], check=check_method)
    assert "\n" not in str(e.value) and "method 'new'" in str(e.value)


def test_a_new_row_that_can_run_is_accepted():
    row = Method("em-true-r", "DBN-EM, R known", "EM transitions, true rewards", "true", "em")
    table = Registry("method", [*METHODS.values(), row], check=check_method)
    assert table["em-true-r"].uses_em_init and table["em-true-r"].learns


def test_get_method_is_the_table_s_lookup():
    assert get_method("dbn-em") is METHODS["dbn-em"]
    with pytest.raises(UnknownNameError, match=r"did you mean 'mirl-t'"):
        get_method("mirl_t")
    learners = r"known: mirl-t, mirl, known-r-t, known-r, dbn-em, oracle\)$"
    with pytest.raises(UnknownNameError, match=learners):
        get_method("random", LEARNING_METHODS)
    with pytest.raises(ValueError):  # the error is a ValueError too, as it was
        get_method("nope")
