"""Reinforcement-learning environments over a scenario, for comparing a learned penetration
policy with mirl's planner: :class:`PenetrationEnv`, a ``gymnasium.Env`` of L's task (the
patrollers follow their true policies inside), and :class:`TeamEnv`, a PettingZoo
``ParallelEnv`` in which every robot — each patroller and L — is an agent.

This stage sits beside :mod:`mirl.experiments` (it steps a world of :data:`mirl.worlds.WORLDS`
through the world contract, as runs do, and never uses the learner) and needs the optional
extra ``pip install mirl[envs]`` (gymnasium, pettingzoo); the names load on first use.
"""

from __future__ import annotations

from importlib import import_module
from typing import Any

__all__ = ["PenetrationEnv", "TeamEnv"]

_EXPORTS = {"PenetrationEnv": "mirl.envs.penetration", "TeamEnv": "mirl.envs.team"}


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'mirl.envs' has no attribute {name!r}")
    try:
        module = import_module(_EXPORTS[name])
    except ModuleNotFoundError as exc:
        if exc.name in ("gymnasium", "pettingzoo"):
            raise ImportError(
                f"mirl.envs.{name} needs {exc.name}: pip install 'mirl[envs]'"
            ) from None
        raise
    return getattr(module, name)
