"""L's side: its own MDP and detection model, the belief filter that predicts the patrollers
under the learned models, the time-indexed go decision, and the random baseline's go time.

It may import :mod:`mirl.learning` (the learned-model records), :mod:`mirl.world` and
:mod:`mirl.mdp`.
"""
