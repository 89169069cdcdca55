"""The estimators' parameter protocol (``mirl._estimator``): scikit-learn's get_params /
set_params / repr, from each estimator's ``__init__``."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from mirl import OccludedMaxEntIRL, TransitionFeatureLearner, load_scenario

DOMAIN = load_scenario("boyd2").domain


def _make(cls, **params):
    return cls(DOMAIN, **params) if cls is TransitionFeatureLearner else cls(**params)


@pytest.mark.parametrize("cls", [OccludedMaxEntIRL, TransitionFeatureLearner])
def test_get_params_is_init_s_arguments_and_rebuilds_the_estimator(cls):
    names = [n for n in inspect.signature(cls.__init__).parameters if n != "self"]
    est = _make(cls)
    params = est.get_params()
    assert list(params) == names
    again = cls(**params)  # what sklearn.base.clone does
    assert again.get_params().keys() == params.keys()
    assert all(again.get_params()[k] is v for k, v in params.items())


def test_set_params_changes_validates_and_refuses_by_name():
    est = OccludedMaxEntIRL(l2=0.5)
    assert est.set_params(temperature=2.0, n_restarts=3) is est
    assert (est.temperature, est.n_restarts, est.l2) == (2.0, 3, 0.5)
    with pytest.raises(ValueError, match="l2 must be at least 0, got -1"):
        est.set_params(l2=-1, temperature=5.0)
    assert (est.l2, est.temperature) == (0.5, 2.0)  # nothing changed by a refused call
    with pytest.raises(ValueError, match="no parameter 'optimiser' .*did you mean 'optimizer'"):
        est.set_params(optimiser="lbfgs")
    with pytest.raises(ValueError, match="unknown optimizer 'bfgs'"):
        est.set_params(optimizer="bfgs")


def test_the_repr_shows_the_settings_that_differ_from_the_defaults():
    assert repr(OccludedMaxEntIRL()) == "OccludedMaxEntIRL()"
    assert repr(OccludedMaxEntIRL(l2=0.5, random_state=3)) == (
        "OccludedMaxEntIRL(l2=0.5, random_state=3)"
    )
    rng = np.random.default_rng(0)
    shown = repr(OccludedMaxEntIRL(random_state=rng))
    assert shown == "OccludedMaxEntIRL(random_state=<Generator>)"  # no address: reprs compare
    assert repr(TransitionFeatureLearner(DOMAIN, method="paper")) == (
        "TransitionFeatureLearner(domain=<PatrolDomain>, method='paper')"
    )


def test_an_unknown_solver_is_refused_when_the_learner_is_made_not_when_it_fits():
    with pytest.raises(ValueError, match="unknown method 'maxnet' .*did you mean 'maxent'"):
        TransitionFeatureLearner(DOMAIN, method="maxnet")
