"""A small typed reader for data files parsed from TOML: every value is checked for its type and
range where it is read, and every refusal is one :class:`FieldError` whose message starts with
the field's path (``robots[2].weights.moved: ...``).

Why not pydantic: the scenario format has a dozen fields whose checks depend on each other (cells
on *this* map, weights for *these* reward features, robot names of *this* team), so most checks
are code either way; a dependency for the remaining type checks would cost an import of ~0.2 s
and messages in pydantic's own wording. These readers are strict by design: a boolean is never a
number, a fraction is never an integer, ``nan``/``inf`` are refused, and a misspelt key is an
error, not silently ignored.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from mirl.world.maps import MapFrame

__all__ = [
    "FieldError",
    "table",
    "number",
    "integer",
    "string",
    "name",
    "array",
    "cell",
]


class FieldError(ValueError):
    """One bad field: ``path`` and what is wrong with it.

    Parameters
    ----------
    path : str
        The field's dotted path in the file (``robots[1].start``).
    problem : str
        What is wrong with it.
    """

    def __init__(self, path: str, problem: str) -> None:
        super().__init__(f"{path}: {problem}" if path else problem)
        self.path = path


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def table(value: Any, path: str, keys: Iterable[str], required: Iterable[str] = ()) -> dict:
    """A table with only known keys (a misspelt key must not be silently ignored).

    Parameters
    ----------
    value : object
        The value read.
    path : str
        Its field path.
    keys : iterable of str
        The keys it may have.
    required : iterable of str, default ()
        The keys it must have.

    Returns
    -------
    dict
        ``value`` itself.

    Raises
    ------
    FieldError
        Not a table, an unknown key, or a missing one.
    """
    known = set(keys)
    if not isinstance(value, dict):
        raise FieldError(path, f"expected a table, got {_show(value)}")
    unknown = sorted(set(value) - known)
    if unknown:
        where = f"{path}.{unknown[0]}" if path else unknown[0]
        raise FieldError(where, f"unknown field (known: {', '.join(sorted(known))})")
    for key in required:
        if key not in value:
            raise FieldError(path, f"missing field '{key}'")
    return value


def number(
    value: Any,
    path: str,
    *,
    low: float | None = None,
    high: float | None = None,
    high_open: bool = False,
) -> float:
    """A finite real number (an integer or a float, never a boolean) in [low, high].

    Parameters
    ----------
    value : object
        The value read.
    path : str
        Its field path.
    low : float, optional
        The least value allowed.
    high : float, optional
        The greatest value allowed.
    high_open : bool, default False
        Whether ``high`` itself is refused ([low, high)).

    Returns
    -------
    float
        The number.

    Raises
    ------
    FieldError
        Not a finite number, or out of range.
    """
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise FieldError(path, f"expected a number, got {_show(value)}")
    x = float(value)
    if not math.isfinite(x):
        raise FieldError(path, f"expected a finite number, got {_show(value)}")
    if low is not None and x < low:
        raise FieldError(path, f"must be at least {low:g}, got {x:g}")
    if high is not None and (x > high or (high_open and x >= high)):
        bound = f"below {high:g}" if high_open else f"at most {high:g}"
        raise FieldError(path, f"must be {bound}, got {x:g}")
    return x


def integer(value: Any, path: str, *, low: int | None = None, high: int | None = None) -> int:
    """An integer (a float such as 2.5 or 2.0 is refused: a fraction is not a count).

    Parameters
    ----------
    value : object
        The value read.
    path : str
        Its field path.
    low : int, optional
        The least value allowed.
    high : int, optional
        The greatest value allowed.

    Returns
    -------
    int
        The integer.

    Raises
    ------
    FieldError
        Not an integer, or out of range.
    """
    if isinstance(value, bool) or not isinstance(value, int):
        raise FieldError(path, f"expected an integer, got {_show(value)}")
    if low is not None and value < low:
        raise FieldError(path, f"must be at least {low}, got {value}")
    if high is not None and value > high:
        raise FieldError(path, f"must be at most {high}, got {value}")
    return int(value)


def string(value: Any, path: str, choices: Iterable[str] | None = None) -> str:
    """A string, optionally one of ``choices``.

    Parameters
    ----------
    value : object
        The value read.
    path : str
        Its field path.
    choices : iterable of str, optional
        The strings allowed.

    Returns
    -------
    str
        The string.

    Raises
    ------
    FieldError
        Not a string, or not one of ``choices``.
    """
    if not isinstance(value, str):
        raise FieldError(path, f"expected a string, got {_show(value)}")
    if choices is not None:
        allowed = tuple(choices)
        if value not in allowed:
            raise FieldError(path, f"'{value}' is not one of {', '.join(allowed)}")
    return value


# --damage ROBOT:FEATURE=P and --topic TOPIC=ROBOT split on these characters and strip what
# they read; a report prints name=value
_NAME_BREAKERS = ",:=\n\r"


def name(value: Any, path: str, what: str) -> str:
    """A name of a robot or a feature: one the command line can give and a report can print.

    Parameters
    ----------
    value : object
        The value read.
    path : str
        Its field path.
    what : str
        What it names ("robot", "reward feature"), for the message.

    Returns
    -------
    str
        The name.

    Raises
    ------
    FieldError
        Not a string; empty or only space; space at either end; or with ``,``, ``:``, ``=`` or
        a line break.
    """
    text = string(value, path)
    if not text.strip() or text != text.strip() or any(ch in text for ch in _NAME_BREAKERS):
        raise FieldError(
            path,
            f"{text!r} is not a usable {what} name (it needs a character other than space, "
            "none at either end, and none of , : = or a line break)",
        )
    return text


def array(value: Any, path: str, *, length: int | None = None, min_length: int = 0) -> list:
    """A list (or, from Python callers, a tuple).

    Parameters
    ----------
    value : object
        The value read.
    path : str
        Its field path.
    length : int, optional
        The exact number of entries required.
    min_length : int, default 0
        The least number of entries.

    Returns
    -------
    list
        The entries.

    Raises
    ------
    FieldError
        Not a list, or of the wrong length.
    """
    if not isinstance(value, list | tuple):  # TOML gives lists; Python callers may pass tuples
        raise FieldError(path, f"expected a list, got {_show(value)}")
    value = list(value)
    if length is not None and len(value) != length:
        raise FieldError(path, f"expected {length} entries, got {len(value)}")
    if len(value) < min_length:
        raise FieldError(path, f"expected at least {min_length} entries, got {len(value)}")
    return value


def cell(
    value: Any,
    path: str,
    shape: tuple[int, int] | None = None,
    n: int = 2,
    frame: MapFrame | None = None,
) -> tuple:
    """(row, col) — or (row, col, heading) with ``n = 3`` — of non-negative integers inside a map.

    A negative index must never wrap around to the other side. With a map ``frame``, a position
    may also be a point in metres: ``{x, y}`` for a cell, ``{x, y, yaw}`` (yaw in degrees, rounded
    to the nearest heading; one halfway between two is refused) for a state; it is read as the
    cell whose centre is nearest and must lie on the grid.

    Parameters
    ----------
    value : object
        The value read.
    path : str
        Its field path.
    shape : (int, int), optional
        The map's (rows, cols); unchecked if None.
    n : {2, 3}, default 2
        2 for a cell, 3 for a state with its heading.
    frame : MapFrame, optional
        The map's frame, to accept points in metres.

    Returns
    -------
    tuple of int
        (row, col) or (row, col, heading).

    Raises
    ------
    FieldError
        Malformed, or off the map.
    """
    if isinstance(value, dict) and frame is not None:
        return _metric_cell(value, path, shape, n, frame)
    if (
        not isinstance(value, list | tuple)
        or len(value) != n
        or not all(isinstance(v, int) and not isinstance(v, bool) for v in value)
    ):
        what = "[row, col]" if n == 2 else "[row, col, heading]"
        if frame is not None:
            what += " as integers or " + ("{ x, y }" if n == 2 else "{ x, y, yaw }")
            raise FieldError(path, f"expected {what} in metres, got {_show(value)}")
        raise FieldError(path, f"expected {what} as integers, got {_show(value)}")
    if any(v < 0 for v in value):
        raise FieldError(path, f"{list(value)} has a negative coordinate")
    if shape is not None and (value[0] >= shape[0] or value[1] >= shape[1]):
        raise FieldError(path, f"{list(value)} is off the {shape[0]}x{shape[1]} map")
    if n == 3 and value[2] > 3:
        raise FieldError(path, f"heading {value[2]} is not 0-3 (east, north, west, south)")
    return tuple(int(v) for v in value)


def _metric_cell(value: dict, path: str, shape, n: int, frame: MapFrame) -> tuple:
    keys = ("x", "y") if n == 2 else ("x", "y", "yaw")
    value = table(value, path, keys, required=keys)
    # far beyond any building (maps.MAX_FRAME_ORIGIN), so that cell arithmetic cannot overflow
    x = number(value["x"], f"{path}.x", low=-1e9, high=1e9)
    y = number(value["y"], f"{path}.y", low=-1e9, high=1e9)
    r, c = (int(v) for v in frame.cell_of(x, y))
    if r < 0 or c < 0 or (shape is not None and (r >= shape[0] or c >= shape[1])):
        where = ""
        if shape is not None:
            x0, y0 = frame.cell_centre(0, 0)
            x1, y1 = frame.cell_centre(shape[0] - 1, shape[1] - 1)
            half = frame.cell_size / 2
            where = (
                f" (x {float(x0) - half:g} to {float(x1) + half:g} m, "
                f"y {float(y1) - half:g} to {float(y0) + half:g} m)"
            )
        raise FieldError(path, f"x = {x:g}, y = {y:g} m is off the map{where}")
    if n == 2:
        return (r, c)
    # degrees, one turn either way: beyond it a yaw is more likely a slip (a radian count,
    # an exponent) than a heading meant, and 1e300 % 90 is no heading of any kind
    yaw = number(value["yaw"], f"{path}.yaw", low=-360.0, high=360.0)
    if abs(yaw % 90.0 - 45.0) < 1e-9:  # no nearest heading: rounding would pick one unsaid
        raise FieldError(f"{path}.yaw", f"{yaw:g}° is halfway between two headings")
    return (r, c, int(round(yaw / 90.0)) % 4)
