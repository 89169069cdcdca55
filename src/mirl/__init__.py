"""mirl: learn how other robots behave — rewards, policies and faulty motion — from mostly
occluded observations (Bogert & Doshi, mIRL*/T+Int), and act on it.

The entry points a user needs are importable from here (``from mirl import load_scenario,
simulate, learn, run_episode``); they are loaded on first use, so ``import mirl`` stays cheap.
The package is layered by pipeline stage, and a stage imports only the stages before it
(checked by import-linter; docs/design.md, "Layers"): :mod:`mirl.mdp` → :mod:`mirl.world` →
:mod:`mirl.observations` → :mod:`mirl.simulation` | :mod:`mirl.physics` (the grid simulator |
the MuJoCo world) → :mod:`mirl.learning` → :mod:`mirl.planning` → :mod:`mirl.worlds` (the
world contract and its table) → :mod:`mirl.experiments` | :mod:`mirl.envs` (runs and sweeps |
gymnasium and PettingZoo environments) → :mod:`mirl.viz` → :mod:`mirl.cli`; ``a | b`` are
siblings that do not import each other. Below every stage: ``mirl.sparse`` (the shared sparse
kernels), ``mirl._validation`` (options declared once) and ``mirl._registry`` (the one table
type).
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

# public name -> module that defines it
_EXPORTS = {
    "TabularMDP": "mirl.mdp",
    "value_iteration": "mirl.mdp",
    "GridMap": "mirl.world.maps",
    "MapFrame": "mirl.world.maps",
    "load_map": "mirl.world.catalog",
    "Scenario": "mirl.world.scenario",
    "load_scenario": "mirl.world.scenario",
    "PatrolDomain": "mirl.world.domain",
    "transition_matrix": "mirl.world.motion",
    "Trajectories": "mirl.observations.trajectories",
    "read_csv": "mirl.observations.trajectories",
    "PatrolSimulator": "mirl.simulation.grid",
    "simulate": "mirl.simulation.grid",
    "solve_feature_probabilities": "mirl.learning.feature_solver",
    "TransitionFeatureLearner": "mirl.learning.transitions",
    "IRLProblem": "mirl.learning.irl",
    "OccludedMaxEntIRL": "mirl.learning.irl",
    "learn": "mirl.learning.learn",
    "LearnResult": "mirl.learning.results",
    "BeliefFilter": "mirl.planning.belief",
    "observer_model": "mirl.planning.observer",
    "solve_observer_mdp": "mirl.planning.go",
    "run_episode": "mirl.experiments.episode",
    "RunResult": "mirl.experiments.records",
    "LearnOptions": "mirl.learning.options",
    "RunProtocol": "mirl.experiments.options",
    "SweepOptions": "mirl.experiments.options",
    "OptionError": "mirl._validation",
}

__all__ = [
    "__version__",
    "TabularMDP",
    "value_iteration",
    "GridMap",
    "MapFrame",
    "load_map",
    "Scenario",
    "load_scenario",
    "PatrolDomain",
    "transition_matrix",
    "Trajectories",
    "read_csv",
    "PatrolSimulator",
    "simulate",
    "solve_feature_probabilities",
    "TransitionFeatureLearner",
    "IRLProblem",
    "OccludedMaxEntIRL",
    "learn",
    "LearnResult",
    "BeliefFilter",
    "observer_model",
    "solve_observer_mdp",
    "run_episode",
    "RunResult",
    "LearnOptions",
    "RunProtocol",
    "SweepOptions",
    "OptionError",
]


def __getattr__(name: str) -> Any:
    # PEP 562: import the defining module on first use (keeps `mirl --version` fast)
    if name == "__version__":
        from mirl._version import package_version

        globals()[name] = value = package_version()
        return value
    if name in _EXPORTS:
        value = getattr(import_module(_EXPORTS[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'mirl' has no attribute '{name}'")


def __dir__() -> list[str]:
    return sorted(__all__)


if TYPE_CHECKING:  # for type checkers and IDEs: the same names, imported eagerly
    __version__: str
    from mirl._validation import OptionError
    from mirl.experiments.episode import run_episode
    from mirl.experiments.options import RunProtocol, SweepOptions
    from mirl.experiments.records import RunResult
    from mirl.learning.feature_solver import solve_feature_probabilities
    from mirl.learning.irl import IRLProblem, OccludedMaxEntIRL
    from mirl.learning.learn import learn
    from mirl.learning.options import LearnOptions
    from mirl.learning.results import LearnResult
    from mirl.learning.transitions import TransitionFeatureLearner
    from mirl.mdp import TabularMDP, value_iteration
    from mirl.observations.trajectories import Trajectories, read_csv
    from mirl.planning.belief import BeliefFilter
    from mirl.planning.go import solve_observer_mdp
    from mirl.planning.observer import observer_model
    from mirl.simulation.grid import PatrolSimulator, simulate
    from mirl.world.catalog import load_map
    from mirl.world.domain import PatrolDomain
    from mirl.world.maps import GridMap, MapFrame
    from mirl.world.motion import transition_matrix
    from mirl.world.scenario import Scenario, load_scenario
