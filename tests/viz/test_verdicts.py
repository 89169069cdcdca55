"""The calibration section of the fault verdicts (mirl.viz.verdicts)."""

from __future__ import annotations

import numpy as np
import pytest

from mirl.experiments.conditions import Condition
from mirl.viz.aggregate import Group
from mirl.viz.verdicts import (
    VerdictItem,
    expected_calibration_error,
    rates_markdown,
    reliability_table,
    verdict_items,
    verdicts_markdown,
)


def _item(conf, right, verdict=("left_wheel",), truth=("left_wheel",)):
    return VerdictItem("grid", 1.0, "J:left_wheel", "J", 0, verdict, conf, truth, right)


def test_a_calibrated_set_has_a_small_error_and_an_overconfident_one_a_large():
    rng = np.random.default_rng(1)
    conf = rng.uniform(0.5, 1.0, 4000)
    calibrated = [_item(c, bool(rng.random() < c)) for c in conf]
    assert expected_calibration_error(calibrated) < 0.03
    overconfident = [_item(c, bool(rng.random() < c - 0.3)) for c in conf]
    assert expected_calibration_error(overconfident) == pytest.approx(0.3, abs=0.03)
    rows = reliability_table(calibrated)
    assert sum(r[2] for r in rows) == len(calibrated)


def test_confident_wrong_and_false_alarms():
    assert _item(0.95, False, ("right_wheel",)).confident_wrong
    assert not _item(0.95, True).confident_wrong
    assert not _item(0.95, False, ()).confident_wrong  # "no part" is not naming damage
    assert _item(0.95, False, ("left_wheel",), ()).false_alarm
    assert not _item(0.85, False, ("left_wheel",), ()).false_alarm


def test_the_section_reads_the_stored_runs(tmp_path):
    cond = Condition("mirl-t", "boyd2-healthy", 1.0, damage="J:left_wheel")
    rows = [
        {
            "run": k, "outcome": "success",
            "verdict.I": "", "confidence.I": 0.99, "truth.I": "", "right.I": 1,
            "verdict.J": "left_wheel", "confidence.J": 0.9, "truth.J": "left_wheel", "right.J": 1,
        }
        for k in range(3)
    ]  # fmt: skip
    group = Group(cond, rows)
    items = verdict_items([group])
    assert len(items) == 6 and all(i.right for i in items)
    md = verdicts_markdown([group], tmp_path)
    assert "J's left wheel | 3 | 1.000 (3/3)" in md
    assert (tmp_path / "verdicts.png").exists()
    rows[1]["unseen.J"] = 1  # L never saw J move in run 1: no verdict to score
    assert len(verdict_items([group])) == 5


def test_the_rates_count_runs_whatever_the_team_size():
    # three healthy robots in each of two runs: 2 runs, 6 verdicts, 5 of them "no part"
    items = [
        VerdictItem("grid", 1.0, None, robot, run, (), 0.95, (), True)
        for run in range(2)
        for robot in ("I", "J", "K")
    ]
    items[-1] = VerdictItem("grid", 1.0, None, "K", 1, ("floor",), 0.6, (), False)
    row = rates_markdown(items).splitlines()[2]
    assert row.startswith("| grid | 1 | none | 2 |"), row
    assert "0.833 (5/6)" in row, row
