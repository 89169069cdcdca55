"""Every way to name a map: a shipped map (text or ROS), a text map file, a ROS ``map_server``
YAML file, or a generated office (``office-60x60``, ``office-40x30-s7``).

The ROS reader (PyYAML, Pillow) and the office generator (``scipy.ndimage``) are imported only
when such a map is asked for, so loading a shipped text map stays cheap.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from mirl.world._resources import read_shipped_or_file, shipped_names
from mirl.world.maps import GridMap, MapError, parse_map

__all__ = ["is_ros_map", "load_map", "shipped_maps"]

_YAML = (".yaml", ".yml")


def shipped_maps() -> list[str]:
    """The names of the maps shipped with mirl, text and ROS, sorted.

    Returns
    -------
    list of str
        Names :func:`load_map` accepts as they are.
    """
    return sorted(shipped_names("maps", ".txt") + shipped_names("maps", ".yaml"))


def is_ros_map(name_or_path: str | Path) -> bool:
    """Whether ``name_or_path`` names a ROS map_server map: a shipped one or a YAML file.

    Parameters
    ----------
    name_or_path : str or Path
        A shipped map's name or a file's path.

    Returns
    -------
    bool
        True for a shipped ROS map's name or a path ending in ``.yaml`` or ``.yml`` (that is not a
        shipped map's name).
    """
    name = str(name_or_path)
    if name in shipped_names("maps", ".yaml"):
        return True
    return name not in shipped_maps() and Path(name).suffix.lower() in _YAML


def load_map(name_or_path: str | Path, *, cell_size: float | None = None) -> GridMap:
    """Load a generated office by name, a shipped map by name, a plain-text map file, or a ROS
    map_server YAML file.

    Parameters
    ----------
    name_or_path : str or Path
        ``office-60x60`` (or ``office-40x30-s7``), a shipped map's name (:func:`shipped_maps`),
        or the path of a text map or a ROS map's YAML file.
    cell_size : float, optional
        Metres per cell for a ROS map; by default that of
        :func:`~mirl.world.ros_maps.load_ros_map`. Other maps ignore it.

    Returns
    -------
    GridMap
        The map.

    Raises
    ------
    MapError
        A name that is neither shipped nor a readable file, or a map that does not parse (the
        message names the file and the problem).
    """
    name = str(name_or_path)
    if name.startswith("office"):
        from mirl.world.office_maps import office_map_from_name

        office = office_map_from_name(name)
        if office is not None:
            return office
    if is_ros_map(name_or_path):
        from mirl.world.ros_maps import load_ros_map

        if name in shipped_names("maps", ".yaml"):
            shipped = resources.files("mirl") / "data" / "maps" / f"{name}.yaml"
            with resources.as_file(shipped) as path:
                gridmap = load_ros_map(path, cell_size=cell_size)
            return gridmap
        return load_ros_map(Path(name_or_path), cell_size=cell_size)
    # the error lists every name this function takes, the ROS maps and generated offices too
    known = f"{', '.join(shipped_maps())}; or a generated office-RxC[-sK]"
    text, source, file = read_shipped_or_file(
        name_or_path, "maps", ".txt", MapError, "map", known=known
    )
    return parse_map(text, name=Path(name).stem if file else name, source=source)
