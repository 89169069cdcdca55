"""Worlds that run: the grid simulator, whose dynamics are Eq. 5 with the scenario's true
feature probabilities, producing true trajectories and L's occluded observations.

It may import :mod:`mirl.observations`, :mod:`mirl.world` and :mod:`mirl.mdp`, and never the
learner: the learner must not mirror the world it is tested in.
"""
