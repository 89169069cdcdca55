"""Learning from observations (mIRL*/T+Int): the Eq. 4 feature solver, transition learning and
labels (mIRL*/T), occluded maximum-entropy IRL, the weighing of equilibria, the DBN-EM baseline,
the :func:`~mirl.learning.learn.learn` entry point with the steps of its rounds
(:mod:`mirl.learning.rounds`) and the learned-model records.

It may import :mod:`mirl.observations`, :mod:`mirl.world` and :mod:`mirl.mdp` — never a
simulator, so it knows the world only through what L saw.
"""
