"""Every way to name a map: shipped names, files, ROS YAML files and generated offices."""

from __future__ import annotations

import pytest

from mirl.world.catalog import is_ros_map, load_map, shipped_maps
from mirl.world.maps import MapError


def test_shipped_maps_listed():
    assert {"boyd2", "boydright"} <= set(shipped_maps())


def test_missing_map_file(tmp_path):
    path = tmp_path / "nope.txt"
    with pytest.raises(MapError, match="no such file") as exc:
        load_map(path)
    assert str(exc.value).startswith(str(path))


def test_unreadable_map_file(tmp_path):
    path = tmp_path / "binary.txt"
    path.write_bytes(b"\xff\xfe\x00\x81L..\n")
    with pytest.raises(MapError, match="cannot read") as exc:
        load_map(path)
    assert str(exc.value).startswith(str(path))
    d = tmp_path / "dir.txt"
    d.mkdir()
    with pytest.raises(MapError, match="cannot read"):
        load_map(d)


def test_shipped_maps_are_the_text_and_ros_maps_in_the_package():
    names = shipped_maps()
    assert names == sorted(names)
    assert "turtlebot3_world" in names  # the shipped ROS map (YAML + PGM)
    for name in names:
        assert load_map(name).name == name


def test_is_ros_map_by_shipped_name_or_yaml_suffix(tmp_path):
    assert is_ros_map("turtlebot3_world")
    assert not is_ros_map("boyd2")
    assert is_ros_map(tmp_path / "floor.yaml") and is_ros_map(tmp_path / "floor.YML")
    assert not is_ros_map(tmp_path / "floor.txt")


def test_a_text_file_loads_under_its_stem(tmp_path):
    path = tmp_path / "tiny.txt"
    path.write_text("L..G\n#..#\n")
    m = load_map(path)
    assert m.name == "tiny" and m.source == str(path)
    assert m.shape == (2, 4) and m.observer_start == (0, 0) and m.goals == ((0, 3),)


def test_a_text_file_saved_with_a_bom_or_blank_lines_around_loads(tmp_path):
    # Windows editors write a BOM (read in CSVs too); blank lines above the map hold no cells
    path = tmp_path / "tiny.txt"
    path.write_bytes(b"\xef\xbb\xbf\r\n; a note\r\nL..G\r\n#..#\r\n\r\n")
    m = load_map(path)
    assert m.shape == (2, 4) and m.observer_start == (0, 0) and m.goals == ((0, 3),)


def test_office_names_are_generated_and_other_names_fall_through():
    office = load_map("office-20x24-s3")
    assert office.shape == (20, 24) and office.source.startswith("generated office map")
    with pytest.raises(MapError, match="office-2x2"):
        load_map("office-2x2")
    with pytest.raises(MapError, match="no such file.*shipped maps: boyd2"):
        load_map("officeplan")  # not an office name: a file that does not exist


def test_the_shipped_ros_map_takes_a_cell_size():
    coarse, fine = load_map("turtlebot3_world"), load_map("turtlebot3_world", cell_size=0.25)
    assert not coarse.marked and coarse.frame.cell_size == 0.5  # the default
    assert fine.frame.cell_size == 0.25
    assert fine.shape[0] >= 2 * coarse.shape[0] - 1


def test_an_empty_name_is_refused_with_the_shipped_names():
    with pytest.raises(MapError, match=r"an empty map name \(shipped maps: boyd2"):
        load_map(" ")


def test_a_missing_map_lists_every_name_load_map_takes():
    # the list named only the text maps: a user told "shipped maps: boyd2, boydright" did not
    # learn of the shipped ROS map turtlebot3_world or of the generated offices
    for name in ("nosuch", " "):
        with pytest.raises(MapError) as info:
            load_map(name)
        message = str(info.value)
        assert "turtlebot3_world" in message and "office-RxC" in message, message
        assert all(shipped in message for shipped in shipped_maps())
