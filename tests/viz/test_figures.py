"""The report's sections (:mod:`mirl.viz.figures`): a table of the experiments that have one,
each row refused unless its experiment exists."""

from __future__ import annotations

import pytest

from mirl._registry import Registry
from mirl.experiments.conditions import EXPERIMENTS
from mirl.viz.figures import SECTIONS, Section, _check_section


def test_every_listed_experiment_of_the_paper_has_a_section():
    listed = [n for n, e in EXPERIMENTS.items() if not e.hidden]
    assert SECTIONS.names == tuple(listed)
    assert all(isinstance(s, Section) and s.name == n for n, s in SECTIONS.items())


def test_a_section_of_no_experiment_is_refused():
    with pytest.raises(ValueError, match=r"report section 'fig5'.*did you mean 'fig3'"):
        Registry("report section", [Section("fig5", lambda gs, d: "")], check=_check_section)


def test_a_section_is_called_as_its_writer(tmp_path):
    calls = []
    section = Section("fig3", lambda gs, d: calls.append((gs, d)) or "text")
    assert section([], tmp_path) == "text" and calls == [([], tmp_path)]
    # with no runs the figures' sections still answer in words, not with an error
    assert isinstance(SECTIONS["fig4b"]([], tmp_path), str)
