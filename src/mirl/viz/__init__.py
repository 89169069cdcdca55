"""Drawings and reports: maps as text and PNG, a run's paths and go values, the paper's figures
and ``report.md``. matplotlib is imported only here, and only when something is drawn.

It may import every stage below it (experiments and down); only :mod:`mirl.cli` is above.
"""
