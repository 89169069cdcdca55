"""Every way to name a map: a shipped text map, a text map file, a ROS ``map_server`` YAML file,
or a generated office (``office-60x60``, ``office-40x30-s7``).

The ROS reader (PyYAML, Pillow) and the office generator (``scipy.ndimage``) are imported only
when such a map is asked for, so loading a shipped map stays cheap.
"""

from __future__ import annotations

from pathlib import Path

from mirl.world._resources import read_shipped_or_file, shipped_names
from mirl.world.maps import GridMap, MapError, parse_map

__all__ = ["load_map", "shipped_maps"]


def shipped_maps() -> list[str]:
    return shipped_names("maps", ".txt")


def load_map(name_or_path: str | Path, *, cell_size: float | None = None) -> GridMap:
    """Load a generated office by name, a shipped map by name, a plain-text map file, or a ROS
    map_server YAML file (``cell_size`` metres per cell for ROS maps)."""
    name = str(name_or_path)
    if name.startswith("office"):
        from mirl.world.office_maps import office_map_from_name

        office = office_map_from_name(name)
        if office is not None:
            return office
    path = Path(name_or_path)
    if name not in shipped_maps() and path.suffix.lower() in {".yaml", ".yml"}:
        from mirl.world.ros_maps import load_ros_map

        return load_ros_map(path, cell_size=cell_size)
    text, source, file = read_shipped_or_file(name_or_path, "maps", ".txt", MapError, "map")
    return parse_map(text, name=path.stem if file else name, source=source)
