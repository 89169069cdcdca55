"""Learning from observations (mIRL*/T+Int): how L comes by models of the patrollers.

* :mod:`~mirl.learning.methods` — the table of methods: what each is called, where its reward
  and transition models come from;
* :mod:`~mirl.learning.options` — :class:`~mirl.learning.options.LearnOptions`, how ``learn``
  learns, each option declared once, and the names its options choose among;
* :mod:`~mirl.learning.learn` — :func:`~mirl.learning.learn.learn`, the one entry point, which
  builds a method's models and runs the relabelling rounds of mIRL*/T+Int;
* :mod:`~mirl.learning.transitions` — labelling observed steps with actions, and the
  transition-feature learner (mIRL*/T), whose Eq. 4 is solved by
  :mod:`~mirl.learning.feature_solver`;
* :mod:`~mirl.learning.irl` — occluded maximum-entropy IRL, with the likelihood of an occluded
  record in :mod:`~mirl.learning.sequence` and soft values in :mod:`~mirl.learning.soft_policy`;
* :mod:`~mirl.learning.equilibria` — which steps could be meetings, and the weighing of the
  game's equilibria by a joint filter over both robots;
* :mod:`~mirl.learning.dbn_em` — the DBN-EM baseline's transition model;
* :mod:`~mirl.learning.results` — what learning hands on: ``LearnResult``, ``RobotModel``.

The stage's public names are importable from here (``from mirl.learning import
OccludedMaxEntIRL``), loaded on first use so that importing the methods table stays cheap (the
command line reads it at start-up). The entry point is the exception: ``mirl.learning.learn`` is
its module, so the function is ``mirl.learning.learn.learn`` (or ``mirl.learn``).

It may import :mod:`mirl.observations`, :mod:`mirl.world`, :mod:`mirl.mdp` and
:mod:`mirl.sparse` — never a simulator, so it knows the world only through what L saw.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from mirl.learning.methods import LEARNING_METHODS, METHODS, Method, get_method
from mirl.learning.options import LearnOptions

# public name -> module that defines it (imported on first use: they need numpy and scipy)
_EXPORTS = {
    "LoopTrace": "mirl.learning.learn",
    "LearnResult": "mirl.learning.results",
    "RobotModel": "mirl.learning.results",
    "behavior_accuracy": "mirl.learning.results",
    "oracle_models": "mirl.learning.results",
    "IRLProblem": "mirl.learning.irl",
    "OccludedMaxEntIRL": "mirl.learning.irl",
    "TransitionFeatureLearner": "mirl.learning.transitions",
    "solve_feature_probabilities": "mirl.learning.feature_solver",
    "FeatureSolveResult": "mirl.learning.feature_solver",
    "weigh_equilibria": "mirl.learning.equilibria",
    "weigh_team_equilibria": "mirl.learning.equilibria",
    "EquilibriumWeights": "mirl.learning.equilibria",
    "TeamEquilibria": "mirl.learning.equilibria",
    "em_transition_model": "mirl.learning.dbn_em",
}

__all__ = [
    "METHODS",
    "LEARNING_METHODS",
    "Method",
    "get_method",
    "LearnOptions",
    "LoopTrace",
    "LearnResult",
    "RobotModel",
    "behavior_accuracy",
    "oracle_models",
    "IRLProblem",
    "OccludedMaxEntIRL",
    "TransitionFeatureLearner",
    "solve_feature_probabilities",
    "FeatureSolveResult",
    "weigh_equilibria",
    "weigh_team_equilibria",
    "EquilibriumWeights",
    "TeamEquilibria",
    "em_transition_model",
]


def __getattr__(name: str) -> Any:
    # PEP 562: import the defining module on first use
    if name in _EXPORTS:
        value = getattr(import_module(_EXPORTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mirl.learning' has no attribute '{name}'")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


if TYPE_CHECKING:  # for type checkers and IDEs: the same names, imported eagerly
    from mirl.learning.dbn_em import em_transition_model
    from mirl.learning.equilibria import (
        EquilibriumWeights,
        TeamEquilibria,
        weigh_equilibria,
        weigh_team_equilibria,
    )
    from mirl.learning.feature_solver import FeatureSolveResult, solve_feature_probabilities
    from mirl.learning.irl import IRLProblem, OccludedMaxEntIRL
    from mirl.learning.learn import LoopTrace
    from mirl.learning.results import LearnResult, RobotModel, behavior_accuracy, oracle_models
    from mirl.learning.transitions import TransitionFeatureLearner
