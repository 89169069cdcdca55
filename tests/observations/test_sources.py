"""The table of input formats: every file kind is recognised by one row, and a file none
recognises is refused in one line that lists them."""

from __future__ import annotations

import pytest

from mirl.observations.sources import FORMATS, ROBOT_DATA_KINDS, input_format
from mirl.observations.trajectories import TrajectoryError


def test_each_format_recognises_its_files(tmp_path):
    grid = tmp_path / "g.csv"
    grid.write_text("t,robot,row,col,heading\n0,I,0,1,0\n")
    pose = tmp_path / "p.csv"
    pose.write_text("t,robot,x,y,yaw\n0,I,0.0,1.0,0.0\n")
    assert input_format(grid).name == "grid-csv" and not input_format(grid).robot_data
    assert input_format(pose).name == "pose-csv" and input_format(pose).robot_data
    assert set(ROBOT_DATA_KINDS) == {f.name for f in FORMATS.values() if f.robot_data}


def test_a_file_no_format_recognises_is_refused_naming_them_all(tmp_path):
    other = tmp_path / "o.csv"
    other.write_text("time,who,where\n0,I,1\n")
    with pytest.raises(TrajectoryError) as err:
        input_format(other)
    message = str(err.value)
    assert str(other) in message and all(f.description in message for f in FORMATS.values())


def test_the_formats_are_a_table_tried_in_order():
    from mirl._registry import Registry

    assert isinstance(FORMATS, Registry)
    assert FORMATS.names == ("bag", "grid-csv", "pose-csv")  # a bag first: it has no header
    assert FORMATS["pose-csv"].robot_data and not FORMATS["grid-csv"].robot_data
