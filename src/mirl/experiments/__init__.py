"""Experiments: one penetration run end to end (observe, learn, plan, go, score) and its readable
report, the paper's conditions, and the resumable parallel sweep with its SQLite store; how a
run and a sweep go is declared once in :mod:`~mirl.experiments.options`.

It composes the stages below (a world of :mod:`mirl.worlds`, learning, planning); drawing is
:mod:`mirl.viz`.
"""
