"""ROS ``map_server`` maps (YAML + PGM/PNG image) discretised into a
:class:`~mirl.world.maps.GridMap`.

The YAML keys are those of ROS ``map_server`` / nav2 ``map_io``: ``image`` (relative to the YAML
file), ``resolution`` (metres per pixel), ``origin`` ([x, y, yaw]), ``negate``,
``occupied_thresh``, ``free_thresh`` and optional ``mode`` (``trinary`` default, ``scale``,
``raw``). Pixel interpretation follows map_server:

- ``trinary``/``scale``: the pixel value ``x`` is the mean of the colour channels (0–255); the
  occupancy probability is ``p = (255 - x) / 255`` (``p = x / 255`` when ``negate``); a pixel is
  *free* when ``p < free_thresh``. In ``scale`` mode a pixel that is not fully opaque is unknown.
- ``raw``: the pixel value is the occupancy in percent (0–100, anything else unknown); a pixel is
  free when ``x / 100 < free_thresh``.

Unknown and occupied pixels are both "not free". The image is cut into square cells of
``cell_size`` metres (the decision grid; :data:`DEFAULT_CELL_SIZE` unless chosen) starting at
its top-left corner (row 0 of the grid is the top of the image, i.e. the largest map *y*); a
pixel belongs to the cell containing its centre. A cell is hallway only if it is complete (lies
wholly inside the image) and *all* its pixels are free — so a cell never straddles a wall, and a
wall one pixel thick still separates two rooms, at the cost of passages narrower than about two
cells vanishing (docs/design.md, "ROS maps").

A ROS map does not mark L: a plain map loads with placeholder marks (``marked`` is False), and a
scenario gives L's start and goal. The extra YAML keys ``mirl_observer_start: [row, col]`` and
``mirl_goals: [[row, col], ...]`` (cell coordinates at the chosen cell size), or the keyword
arguments of :func:`load_ros_map`, which win, still mark them; the start cell then becomes L's
room (observer-only) and goals stay hallway cells (``G``).
"""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from mirl.world.maps import MAX_FRAME_ORIGIN, MAX_MAP_SIDE, GridMap, MapError, MapFrame

__all__ = [
    "DEFAULT_CELL_SIZE",
    "load_ros_map",
    "occupancy_free_mask",
    "discretise_free_mask",
    "ros_map_frame",
]

# The decision grid of a ROS map when none is chosen: a TurtleBot (0.3-0.35 m across) fits in a
# cell with room to spare, and at its patrol speed (0.2-0.26 m/s) it crosses about one cell in
# a 2 s step, as mirl's motion model assumes (docs/design.md, "ROS maps")
DEFAULT_CELL_SIZE = 0.5

_MODES = ("trinary", "scale", "raw")
YAML_KEYS = (
    "image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh", "mode",
    "mirl_observer_start", "mirl_goals",
)  # fmt: skip
"""The keys a map YAML may have: ROS map_server's and mirl's two for L's start and goals."""
# 64 M pixels: a 400 m x 400 m building at map_server's usual 5 cm a pixel (real maps are a few
# thousand pixels a side); a header claiming more is refused before the pixels are decoded
MAX_MAP_PIXELS = 64 * 2**20
MAX_RESOLUTION = 100.0  # metres a pixel
_EPS = 1e-9


def _one_line(exc: BaseException) -> str:
    return re.sub(r"\s+", " ", f"{exc.__class__.__name__}: {exc}").strip()


def occupancy_free_mask(
    pixels: np.ndarray,
    *,
    negate: bool = False,
    free_thresh: float = 0.196,
    mode: str = "trinary",
    alpha: np.ndarray | None = None,
) -> np.ndarray:
    """(H, W) bool mask of free pixels from map_server pixel values (see module docstring).

    Parameters
    ----------
    pixels : ndarray of shape (H, W)
        Grey values 0–255 (colour images already averaged over channels); occupancy in percent
        in ``raw`` mode.
    negate : bool, default False
        The map_server key ``negate``: white is occupied.
    free_thresh : float, default 0.196
        A pixel is free when its occupancy probability is below this.
    mode : {"trinary", "scale", "raw"}, default "trinary"
        The map_server key ``mode``.
    alpha : ndarray of shape (H, W), optional
        The alpha channel, used only in ``scale`` mode (a pixel not fully opaque is unknown).

    Returns
    -------
    ndarray of bool, shape (H, W)
        True on free pixels.
    """
    x = np.asarray(pixels, dtype=float)
    if mode == "raw":
        return (x >= 0) & (x <= 100) & (x / 100.0 < free_thresh)
    p = x / 255.0 if negate else (255.0 - x) / 255.0
    free = p < free_thresh
    if mode == "scale" and alpha is not None:
        free &= np.asarray(alpha) >= 255
    return free


def discretise_free_mask(free_px: np.ndarray, resolution: float, cell_size: float) -> np.ndarray:
    """(rows, cols) bool: cells of ``cell_size`` metres all of whose pixels are free.

    The pixel with centre at ``(i + 0.5) * resolution`` metres from the top belongs to cell row
    ``floor((i + 0.5) * resolution / cell_size)`` (same for columns). Partial cells at the bottom
    and right edges (not wholly inside the image) are walls.

    Parameters
    ----------
    free_px : ndarray of bool, shape (H, W)
        Free pixels (:func:`occupancy_free_mask`).
    resolution : float
        Metres a pixel.
    cell_size : float
        Metres a cell.

    Returns
    -------
    ndarray of bool, shape (rows, cols)
        True on the cells that are wholly free.
    """
    h, w = free_px.shape
    rows = max(1, math.ceil(h * resolution / cell_size - _EPS))
    cols = max(1, math.ceil(w * resolution / cell_size - _EPS))
    full_rows = math.floor(h * resolution / cell_size + _EPS)
    full_cols = math.floor(w * resolution / cell_size + _EPS)
    ri = np.floor((np.arange(h) + 0.5) * resolution / cell_size + _EPS).astype(int)
    ci = np.floor((np.arange(w) + 0.5) * resolution / cell_size + _EPS).astype(int)
    ri = np.minimum(ri, rows - 1)
    ci = np.minimum(ci, cols - 1)
    blocked = np.zeros((rows, cols), dtype=int)
    count = np.zeros((rows, cols), dtype=int)
    rr, cc = np.meshgrid(ri, ci, indexing="ij")
    np.add.at(blocked, (rr, cc), ~free_px)
    np.add.at(count, (rr, cc), 1)
    cells = (count > 0) & (blocked == 0)
    cells[full_rows:, :] = False
    cells[:, full_cols:] = False
    return cells


class _KeyTwice(Exception):
    """A key given twice in one YAML mapping (its name and 1-based line)."""


def _unique_key_loader() -> type:
    """PyYAML's SafeLoader refusing a key given twice in a mapping: safe_load keeps the last
    silently, so an edited ``resolution:`` above a forgotten one would place the map wrongly."""
    import yaml

    class UniqueKeyLoader(yaml.SafeLoader):
        def construct_mapping(self, node: Any, deep: bool = False) -> Any:
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":  # << merges: later keys override
                    continue
                key = self.construct_object(key_node, deep=deep)
                if not isinstance(key, str | int | float):  # unhashable: SafeLoader refuses it
                    continue
                if key in seen:
                    raise _KeyTwice(key, key_node.start_mark.line + 1)
                seen.add(key)
            return super().construct_mapping(node, deep)

    return UniqueKeyLoader


def _read_yaml(path: Path) -> dict[str, Any]:
    import yaml

    try:
        text = path.read_text()
    except FileNotFoundError:
        raise MapError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise MapError(f"{path}: cannot read map YAML ({_one_line(exc)})") from None
    try:
        data = yaml.load(text, Loader=_unique_key_loader())  # a SafeLoader
    except _KeyTwice as exc:
        key, line = exc.args
        raise MapError(f"{path}: line {line}: key '{key}' given twice; give it once") from None
    except yaml.YAMLError as exc:
        raise MapError(f"{path}: invalid YAML ({_one_line(exc)})") from None
    except RecursionError:  # PyYAML's composer recurses once per nesting level
        raise MapError(f"{path}: invalid YAML (nested too deeply for a map file)") from None
    if not isinstance(data, dict):
        raise MapError(f"{path}: expected a YAML mapping with map_server keys (image, resolution…)")
    return data


def _number(path: Path, data: dict[str, Any], key: str, default: float | None = None) -> float:
    if key not in data:
        if default is None:
            raise MapError(f"{path}: missing key '{key}'")
        return default
    value = data[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise MapError(f"{path}: '{key}' must be a number, got {value!r}")
    return float(value)


def _is_cell(value: Any) -> bool:
    return (
        isinstance(value, list | tuple)
        and len(value) == 2
        and all(isinstance(v, int | np.integer) and not isinstance(v, bool) for v in value)
    )


def _cell(path: Path, what: str, value: Any) -> tuple[int, int]:
    if not _is_cell(value):
        raise MapError(f"{path}: {what} must be a cell [row, col] of integers, got {value!r}")
    return int(value[0]), int(value[1])


def _cells(path: Path, what: str, value: Any) -> list[tuple[int, int]]:
    if _is_cell(value):
        return [_cell(path, what, value)]  # a single [row, col]
    if not isinstance(value, list | tuple) or not value:
        raise MapError(f"{path}: {what} must be a non-empty list of cells [[row, col], ...]")
    return [_cell(path, what, v) for v in value]


def _read_image(path: Path, image_path: Path) -> tuple[np.ndarray, np.ndarray | None]:
    """Grey values 0..255 (mean of the colour channels) and the alpha channel, if any."""
    from PIL import Image, UnidentifiedImageError

    try:
        with warnings.catch_warnings():
            # Pillow warns from 89 M pixels; the limit below, checked before decoding, is lower
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            img = Image.open(image_path)
        with img:
            if img.width * img.height > MAX_MAP_PIXELS:
                raise MapError(
                    f"{path}: image {image_path} is {img.width} x {img.height} pixels, more than "
                    f"the limit of {MAX_MAP_PIXELS // 2**20} M pixels for a map"
                )
            img.load()
            if img.mode.startswith("I"):
                # 16-bit greyscale (PGM with maxval > 255): Pillow scales it to 0..65535
                return np.asarray(img, dtype=float) / 257.0, None
            if img.mode in ("1", "L", "F"):
                return np.asarray(img.convert("L") if img.mode == "1" else img, dtype=float), None
            if img.mode == "LA":
                la = np.asarray(img, dtype=float)
                return la[..., 0], la[..., 1]
            has_alpha = "A" in img.mode or "transparency" in img.info
            rgba = np.asarray(img.convert("RGBA"), dtype=float)
    except MapError:
        raise
    except Image.DecompressionBombError:  # Pillow's own limit (2 x 89 M pixels) came first
        raise MapError(
            f"{path}: image {image_path} has more than the limit of "
            f"{MAX_MAP_PIXELS // 2**20} M pixels for a map"
        ) from None
    except FileNotFoundError:
        raise MapError(f"{path}: image file {image_path} not found") from None
    except UnidentifiedImageError:
        raise MapError(f"{path}: cannot read image {image_path} (not a PGM/PNG image)") from None
    except (OSError, ValueError, SyntaxError) as exc:
        raise MapError(f"{path}: cannot read image {image_path} ({_one_line(exc)})") from None
    return rgba[..., :3].mean(axis=2), (rgba[..., 3] if has_alpha else None)


def load_ros_map(
    yaml_path: str | Path,
    *,
    cell_size: float | None = None,
    observer_start: tuple[int, int] | None = None,
    goals: list[tuple[int, int]] | tuple[tuple[int, int], ...] | None = None,
) -> GridMap:
    """Load a ROS ``map_server`` map and discretise it into cells of ``cell_size`` metres.

    Without ``observer_start`` and ``goals`` (here or as YAML keys) the map is unmarked (module
    doc).

    Parameters
    ----------
    yaml_path : str or Path
        The map's YAML file; its ``image`` is read relative to it.
    cell_size : float, optional
        Metres a cell; :data:`DEFAULT_CELL_SIZE` (or the map resolution, if coarser) by default.
        Not smaller than the resolution, and the grid may have at most
        :data:`~mirl.world.maps.MAX_MAP_SIDE` cells a side.
    observer_start : (int, int), optional
        L's start (row, col) in cells; overrides the YAML key ``mirl_observer_start``.
    goals : sequence of (int, int), optional
        L's goals (row, col) in cells; override the YAML key ``mirl_goals``.

    Returns
    -------
    GridMap
        The map, its frame placed by the YAML's origin (:func:`ros_map_frame`).

    Raises
    ------
    MapError
        Every problem, in one line starting with the YAML path.
    """
    path = Path(yaml_path)
    data = _read_yaml(path)

    unknown = [k for k in data if k not in YAML_KEYS]
    if unknown:  # a misspelt key would leave its setting at the default without a word
        raise MapError(
            f"{path}: unknown key {unknown[0]!r} (a map YAML's keys: {', '.join(YAML_KEYS)})"
        )
    if "image" not in data:
        raise MapError(f"{path}: missing key 'image'")
    if not isinstance(data["image"], str) or not data["image"]:
        raise MapError(f"{path}: 'image' must be a file name, got {data['image']!r}")
    resolution = _number(path, data, "resolution")
    if not 0 < resolution <= MAX_RESOLUTION:
        raise MapError(
            f"{path}: 'resolution' must be in (0, {MAX_RESOLUTION:g}] m a pixel, got {resolution}"
        )
    origin = data.get("origin")
    if origin is None:
        raise MapError(f"{path}: missing key 'origin'")
    if (
        not isinstance(origin, list | tuple)
        or len(origin) != 3
        or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
            for v in origin
        )
    ):
        raise MapError(f"{path}: 'origin' must be [x, y, yaw] numbers, got {origin!r}")
    if max(abs(origin[0]), abs(origin[1])) > MAX_FRAME_ORIGIN:
        raise MapError(
            f"{path}: 'origin' x and y must be within {MAX_FRAME_ORIGIN:g} m, got {origin!r}"
        )
    negate_raw = data.get("negate", 0)
    if negate_raw not in (0, 1, True, False):
        raise MapError(f"{path}: 'negate' must be 0 or 1, got {negate_raw!r}")
    negate = bool(negate_raw)
    occupied_thresh = _number(path, data, "occupied_thresh", 0.65)
    free_thresh = _number(path, data, "free_thresh", 0.196)
    if not 0.0 <= free_thresh <= occupied_thresh <= 1.0:
        raise MapError(
            f"{path}: need 0 <= free_thresh <= occupied_thresh <= 1, "
            f"got free_thresh={free_thresh}, occupied_thresh={occupied_thresh}"
        )
    mode = str(data.get("mode", "trinary")).lower()
    if mode not in _MODES:
        raise MapError(f"{path}: unknown mode {data.get('mode')!r} (expected one of {_MODES})")

    if cell_size is None:
        cell_size = max(DEFAULT_CELL_SIZE, resolution)
    if not (isinstance(cell_size, int | float) and math.isfinite(cell_size) and cell_size > 0):
        raise MapError(
            f"{path}: `cell_size` must be a positive number of metres, got {cell_size!r}"
        )
    if cell_size < resolution * (1 - _EPS):
        raise MapError(
            f"{path}: `cell_size` {cell_size:g} m is smaller than the map resolution "
            f"{resolution:g} m"
        )

    image_path = Path(data["image"])
    if not image_path.is_absolute():
        image_path = path.parent / image_path
    grey, alpha = _read_image(path, image_path)
    _check_grid_size(path, grey.shape, resolution, float(cell_size))
    free_px = occupancy_free_mask(
        grey, negate=negate, free_thresh=free_thresh, mode=mode, alpha=alpha
    )
    free = discretise_free_mask(free_px, resolution, float(cell_size))
    rows, cols = free.shape

    hint = (
        "give L's start and goal in a scenario's [observer] table, or add "
        "'mirl_observer_start: [row, col]' and 'mirl_goals: [[row, col], ...]' "
        f"(cell coordinates, {rows}x{cols} cells of {cell_size:g} m) to the YAML"
    )
    if observer_start is not None:
        start = _cell(path, "observer start", list(observer_start))
    elif "mirl_observer_start" in data:
        start = _cell(path, "mirl_observer_start", data["mirl_observer_start"])
    else:
        start = None
    if goals is not None:
        goal_list = _cells(path, "goals", [list(g) for g in goals])
    elif "mirl_goals" in data:
        goal_list = _cells(path, "mirl_goals", data["mirl_goals"])
    else:
        goal_list = None
    if (start is None) != (goal_list is None):
        given, missing = ("goal", "start") if start is None else ("start", "goal")
        raise MapError(f"{path}: the map marks L's {given} but not its {missing}; {hint}")
    frame = ros_map_frame(origin, resolution, grey.shape[0], float(cell_size))
    if start is None or goal_list is None:
        return _unmarked(path, free, frame, float(cell_size))

    def check(what: str, rc: tuple[int, int]) -> None:
        r, c = rc
        if not (0 <= r < rows and 0 <= c < cols):
            raise MapError(f"{path}: {what} {list(rc)} is outside the {rows}x{cols} cell grid")
        if not free[r, c]:
            raise MapError(
                f"{path}: {what} {list(rc)} is not a free cell at `cell_size` {cell_size:g} m"
            )

    check("observer start", start)
    for g in goal_list:
        check("goal", g)
        if g == start:
            raise MapError(f"{path}: goal {list(g)} is the observer start cell")
    goal_list = list(dict.fromkeys(goal_list))

    patroller = free.copy()
    patroller[start] = False
    if patroller.sum() < 2:
        raise MapError(f"{path}: fewer than 2 free cells at `cell_size` {cell_size:g} m")
    observer_only = np.zeros_like(free)
    observer_only[start] = True
    return GridMap(
        name=path.stem,
        patroller=patroller,
        observer_only=observer_only,
        observer_start=start,
        goals=tuple(goal_list),
        source=str(path),
        frame=frame,
    )


def _unmarked(path: Path, free: np.ndarray, frame: MapFrame, cell_size: float) -> GridMap:
    """A map without L's marks: every free cell is hallway, and the first and last free cells
    (row-major) stand in for L's start and goal until a scenario gives them."""
    cells = np.argwhere(free)
    if len(cells) < 2:
        raise MapError(f"{path}: fewer than 2 free cells at `cell_size` {cell_size:g} m")
    return GridMap(
        name=path.stem,
        patroller=free,
        observer_only=np.zeros_like(free),
        observer_start=(int(cells[0][0]), int(cells[0][1])),
        goals=((int(cells[-1][0]), int(cells[-1][1])),),
        source=str(path),
        frame=frame,
        marked=False,
    )


def _check_grid_size(path: Path, shape_px: tuple[int, ...], resolution: float, cell: float):
    """Refuse a grid of more than MAX_MAP_SIDE cells a side, naming a cell size that fits."""
    height, width = shape_px[:2]
    side_m = max(height, width) * resolution
    cells = math.ceil(side_m / cell - _EPS)
    if cells <= MAX_MAP_SIDE:
        return
    fits = math.ceil(side_m / MAX_MAP_SIDE / resolution - _EPS) * resolution
    raise MapError(
        f"{path}: the map is {width * resolution:g} x {height * resolution:g} m, {cells} cells "
        f"a side at `cell_size` {cell:g} m, more than the limit of {MAX_MAP_SIDE}; choose a "
        f"`cell_size` of at least {fits:g} m"
    )


def ros_map_frame(origin, resolution: float, height_px: int, cell_size: float) -> MapFrame:
    """The map frame of a grid cut from a ``map_server`` image.

    Grid row 0 is the top of the image, so the centre of cell (0, 0) is ``cell_size / 2`` right
    of the left edge and ``cell_size / 2`` below the top edge (``origin_y + height ·
    resolution``). The origin's yaw is ignored, as map_server's own consumers (costmaps, AMCL)
    ignore it.

    Parameters
    ----------
    origin : sequence of float
        The map-frame pose [x, y, yaw] of the image's lower-left corner.
    resolution : float
        Metres a pixel.
    height_px : int
        The image's height in pixels.
    cell_size : float
        Metres a cell.

    Returns
    -------
    MapFrame
        The grid's frame.
    """
    top = float(origin[1]) + height_px * resolution
    return MapFrame(
        cell_size=cell_size,
        origin_x=float(origin[0]) + cell_size / 2.0,
        origin_y=top - cell_size / 2.0,
    )
