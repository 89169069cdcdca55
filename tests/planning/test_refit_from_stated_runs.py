"""``benchmarks/fit_chance_calibration.py`` refits the maps from runs stated through an earlier
map (``--stated-through``): such a run is taken back to the average and range it had before that
map, and restated through the shipped one exactly as a run made now states it."""

from __future__ import annotations

import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mirl.planning.chance_calibration import (
    FIXED_OBSERVATION,
    ChanceMap,
    calibrate_chance,
    calibration_protocols,
    maps_to_json,
)

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import fit_chance_calibration as fcc  # noqa: E402


@pytest.fixture
def earlier_maps(tmp_path, monkeypatch):
    """A calibration file whose fixed-observation map of mirl-t differs from the shipped one."""
    shipped = dict(calibration_protocols())
    before = shipped[FIXED_OBSERVATION]
    earlier = ChanceMap(0.4, 0.7, -0.5, 0.2, runs=400, fitted_on="an earlier fit")
    shipped[FIXED_OBSERVATION] = replace(before, maps={**before.maps, "mirl-t": earlier})
    path = tmp_path / "maps.json"
    path.write_text(maps_to_json(shipped), encoding="utf-8")
    monkeypatch.setattr(fcc, "STATED_THROUGH", fcc._maps_in(str(path)))
    return earlier


def _row(stated, interval, averaged):
    return {
        "method": "mirl-t", "scenario": "boyd2", "world": "grid", "observability": 0.14,
        "view": 0.129, "run": 0, "base": 0, "outcome": "success", "stated": stated,
        "interval": list(interval), "averaged": averaged, "averaged_interval": None,
    }  # fmt: skip


@pytest.mark.parametrize(
    "averaged, lo, hi", [(0.31, 0.2, 0.45), (0.72, 0.6, 0.81), (0.05, 0.01, 0.2)]
)
def test_a_run_stated_through_an_earlier_map_is_restated_through_the_shipped_one(
    earlier_maps, averaged, lo, hi
):
    width, view = hi - lo, 0.129
    stated = float(earlier_maps(averaged, width, view))
    interval = tuple(float(x) for x in earlier_maps(np.array([lo, hi]), width, view))
    row = _row(stated, interval, averaged)
    # back to what it was before the earlier map
    assert fcc._unmapped_interval(row, FIXED_OBSERVATION) == pytest.approx((lo, hi), abs=1e-9)
    # then through the shipped map, as a run made now would state it
    now = fcc._as_stated(row, FIXED_OBSERVATION)
    expected = calibrate_chance("mirl-t", averaged, (lo, hi), view, FIXED_OBSERVATION)
    assert expected is not None
    assert now["stated"] == pytest.approx(expected[0], abs=1e-12)
    assert now["interval"] == pytest.approx(list(expected[1]), abs=1e-9)
    assert now["averaged"] == averaged
    assert now["stated"] != pytest.approx(stated, abs=1e-3)  # the two maps differ here


def test_the_maps_file_of_another_revision_is_read_as_written(tmp_path):
    text = maps_to_json(calibration_protocols())
    path = tmp_path / "maps.json"
    path.write_text(text, encoding="utf-8")
    read = fcc._maps_in(str(path))
    assert set(read) == set(json.loads(text)["protocols"])
    for protocol, fitted in calibration_protocols().items():
        assert read[protocol] == dict(fitted.maps)
