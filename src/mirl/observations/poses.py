"""Pose tracks: continuous robot poses (t in seconds, robot, x, y in metres, yaw in radians, map
frame) as columns of numpy arrays, with CSV input and output.

A pose CSV has the header ``t,robot,x,y,yaw`` or ``t,robot,x,y,qz,qw`` (a planar quaternion:
yaw = 2·atan2(qz, qw)), or ``qx,qy,qz,qw`` (a full quaternion, its yaw read as a bag's is);
other columns are ignored. It is read with ``pyarrow.csv`` (vectorised
C++; see :mod:`mirl.observations` for the measurements). Every problem is a one-line
:class:`PoseError` naming the file and, where there is one, the line.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mirl.observations._csv import (
    NotText,
    arrow_read,
    csv_header,
    data_line_numbers,
    repeated_column,
    text_lines,
    write_columns,
)

__all__ = [
    "PoseTracks",
    "PoseError",
    "read_pose_csv",
    "write_pose_csv",
    "yaw_from_quaternion",
    "POSE_HEADER",
]

POSE_HEADER = ("t", "robot", "x", "y", "yaw")


class PoseError(ValueError):
    """Pose data that cannot be used; the one-line message names the file (and topic or line)."""


@dataclass(frozen=True)
class PoseTracks:
    """One row per pose message: ``robot`` indexes ``robot_names``; float64 seconds, metres and
    radians in the map frame. Readers return rows sorted by (robot, t), stable.

    Parameters
    ----------
    robot_names : tuple of str
        The robots' names; row ``i`` is of ``robot_names[robot[i]]``.
    t : array_like of float, shape (n,)
        Each pose's time (s).
    robot : array_like of int, shape (n,)
        Each pose's robot, an index into ``robot_names``.
    x : array_like of float, shape (n,)
        The map-frame x (m).
    y : array_like of float, shape (n,)
        The map-frame y (m).
    yaw : array_like of float, shape (n,)
        The heading (rad) about the map's z axis.
    source : str, default "<memory>"
        Where the poses came from, as messages name it (a file's path).
    frames : mapping of str to str, default {}
        Robot name -> the frame its poses were read in, as errors name it (``"map"``, or
        ``"map via /tf from base_footprint"``); empty when the source says nothing (a pose CSV).
    unplaced : mapping of str to int, default {}
        Robot name -> stamps read but not placed in the map frame (a TF link with no
        transform).

    Raises
    ------
    PoseError
        Columns of different lengths, or a robot index outside ``robot_names``.
    """

    robot_names: tuple[str, ...]
    t: np.ndarray
    robot: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    source: str = "<memory>"
    # robot name -> the frame its poses were read in, as errors name it ("map", or "map via /tf
    # from base_footprint"); empty when the source says nothing (a pose CSV)
    frames: Mapping[str, str] = field(default_factory=dict)
    # robot name -> stamps read but not placed in the map frame (a TF link with no transform)
    unplaced: Mapping[str, int] = field(default_factory=dict)

    def frame_of(self, robot: str) -> str:
        """`` in frame F`` for messages, or nothing when the frame is unknown.

        Parameters
        ----------
        robot : str
            The robot's name.

        Returns
        -------
        str
            `` in frame 'F'`` with the robot's frame; ``""`` when :attr:`frames` has none.
        """
        frame = self.frames.get(robot)
        return f" in frame '{frame}'" if frame else ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "robot_names", tuple(self.robot_names))
        for name in ("t", "x", "y", "yaw"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=np.float64))
        object.__setattr__(self, "robot", np.asarray(self.robot, dtype=np.int64))
        n = len(self.t)
        if any(len(getattr(self, f)) != n for f in ("robot", "x", "y", "yaw")):
            raise PoseError(f"{self.source}: pose columns have different lengths")
        if n and (self.robot.min() < 0 or self.robot.max() >= len(self.robot_names)):
            raise PoseError(f"{self.source}: robot index outside robot_names")

    def __len__(self) -> int:
        return len(self.t)

    def select(self, mask: np.ndarray) -> PoseTracks:
        """The rows ``mask`` selects, with the same names, source, frames and unplaced counts.

        Parameters
        ----------
        mask : ndarray of bool, shape (n,), or of int
            A boolean mask of the rows, or their indices (in the order wanted).

        Returns
        -------
        PoseTracks
            The selected rows.
        """
        return PoseTracks(
            self.robot_names,
            self.t[mask],
            self.robot[mask],
            self.x[mask],
            self.y[mask],
            self.yaw[mask],
            self.source,
            self.frames,
            self.unplaced,
        )

    def sorted(self) -> PoseTracks:
        """Rows sorted by (robot, t); equal keys keep their order.

        Returns
        -------
        PoseTracks
            The same rows, sorted (stable).
        """
        return self.select(np.lexsort((self.t, self.robot)))

    def counts(self) -> np.ndarray:
        """Poses per robot.

        Returns
        -------
        ndarray of int, shape (len(robot_names),)
            The number of rows of each robot, in :attr:`robot_names`' order.
        """
        return np.bincount(self.robot, minlength=len(self.robot_names))

    def with_robot_names(self, names: Iterable[str]) -> PoseTracks:
        """The same poses indexed into ``names`` (e.g. the scenario's robots, in its order).

        Parameters
        ----------
        names : iterable of str
            The new robot names; every robot of the tracks must be among them (others may be
            added, with no poses).

        Returns
        -------
        PoseTracks
            The poses with ``robot_names`` = ``names``, sorted by (robot, t).

        Raises
        ------
        PoseError
            A robot of the tracks that ``names`` does not have.
        """
        names = tuple(names)
        lut = np.empty(len(self.robot_names), dtype=np.int64)
        for i, n in enumerate(self.robot_names):
            if n not in names:
                known = ", ".join(names)
                raise PoseError(
                    f"{self.source}: robot '{n}' is not in the scenario ({known}); leave its "
                    f"poses out, or say which scenario robot it is with `topics` ({n}=ROBOT)"
                )
            lut[i] = names.index(n)
        return PoseTracks(
            names,
            self.t,
            lut[self.robot],
            self.x,
            self.y,
            self.yaw,
            self.source,
            self.frames,
            self.unplaced,
        ).sorted()

    @classmethod
    def empty(cls, names: Iterable[str] = (), source: str = "<memory>") -> PoseTracks:
        """Tracks with no poses.

        Parameters
        ----------
        names : iterable of str, default ()
            The robots' names.
        source : str, default "<memory>"
            Where the (absent) poses came from.

        Returns
        -------
        PoseTracks
            Zero rows.
        """
        z = np.zeros(0)
        return cls(tuple(names), z, np.zeros(0, dtype=np.int64), z, z, z, source)

    @classmethod
    def concat(cls, parts: list[PoseTracks], source: str | None = None) -> PoseTracks:
        """Rows of all ``parts`` (robot names merged in order of first appearance), sorted.

        Parameters
        ----------
        parts : list of PoseTracks
            The tracks to join.
        source : str or None, default None
            The result's source; None: the first part's (``"<memory>"`` when there are none).

        Returns
        -------
        PoseTracks
            All rows, sorted by (robot, t); frames and unplaced counts merged (a later part's
            entry for a robot replaces an earlier one's).
        """
        if not parts:
            return cls.empty(source=source or "<memory>")
        names: list[str] = []
        for p in parts:
            names.extend(n for n in p.robot_names if n not in names)
        robot = [
            np.asarray([names.index(n) for n in p.robot_names], dtype=np.int64)[p.robot]
            for p in parts
        ]

        def cat(f: str) -> np.ndarray:
            return np.concatenate([getattr(p, f) for p in parts])

        return cls(
            tuple(names),
            cat("t"),
            np.concatenate(robot),
            cat("x"),
            cat("y"),
            cat("yaw"),
            source or parts[0].source,
            {k: v for p in parts for k, v in p.frames.items()},
            {k: v for p in parts for k, v in p.unplaced.items()},
        ).sorted()


# a unit quaternion's components lie in [-1, 1]; an unnormalised one is read as its direction, but
# components past this are no orientation anyone recorded, and their squares overflow (1e300)
MAX_QUATERNION = 1e6


def far_quaternion(components: np.ndarray) -> np.ndarray:
    """(n,) bool: rows of the (n, k) quaternion ``components`` with one beyond
    :data:`MAX_QUATERNION` in magnitude."""
    return (np.abs(components) > MAX_QUATERNION).any(axis=1)


def yaw_from_quaternion(qx, qy, qz, qw) -> np.ndarray:
    """Yaw (rotation about z) of quaternions; the same for any non-zero scale of the quaternion.

    Parameters
    ----------
    qx, qy, qz, qw : array_like of float
        The quaternions' components (scalars or arrays of one shape, or shapes that broadcast).

    Returns
    -------
    ndarray of float
        The yaw, radians in (−π, π], of the broadcast shape.
    """
    qx, qy, qz, qw = (np.asarray(v, dtype=np.float64) for v in (qx, qy, qz, qw))
    return np.arctan2(2.0 * (qw * qz + qx * qy), qw * qw + qx * qx - qy * qy - qz * qz)


# ---- CSV -----------------------------------------------------------------------------------
def _line_of(path: Path, row: int) -> int:
    lines = data_line_numbers(path)
    return int(lines[row]) if row < len(lines) else row + 2


def _is_number(text: str) -> bool:
    """Whether pyarrow reads ``text`` as a float: as ``float`` does, but ASCII digits only and
    no underscores (``1_000``, ``１``), which ``float`` accepts and pyarrow refuses."""
    try:
        float(text)
    except ValueError:
        return False
    return text.isascii() and "_" not in text


def _first_bad_line(path: Path, columns: list[str], numeric: set[str]) -> str:
    """Describe the first row that pyarrow could not parse (error path only)."""
    import csv

    # decoded line by line (a BOM dropped, as csv_header reads it): pyarrow refuses a byte that
    # is not UTF-8 anywhere, and the message names its line
    reader = csv.reader(text_lines(path))
    try:
        header = [h.strip() for h in next(reader, [])]
        idx = {c: header.index(c) for c in columns if c in header}
        for lineno, rec in enumerate(reader, start=2):
            if not rec:
                continue
            if len(rec) != len(header):
                return f"line {lineno}: expected {len(header)} cells, got {len(rec)}"
            for c, i in idx.items():
                if c in numeric and not _is_number(rec[i]):
                    return f"line {lineno}: column {c}: '{rec[i].strip()}' is not a number"
    except NotText as exc:
        return str(exc)
    return "cannot parse"


def _read_arrow_csv(path: Path, header: list[str], columns: dict, numeric: set[str]):
    """:func:`arrow_read`, with a one-line :class:`PoseError` naming the file and line."""
    import pyarrow as pa

    try:
        return arrow_read(path, header, columns)
    except FileNotFoundError:
        raise PoseError(f"{path}: no such file") from None
    except OSError as exc:
        raise PoseError(f"{path}: cannot read ({exc})") from None
    except (pa.ArrowInvalid, pa.ArrowKeyError):
        raise PoseError(f"{path}: {_first_bad_line(path, list(columns), numeric)}") from None


def read_pose_csv(path: str | Path) -> PoseTracks:
    """Read a ``t,robot,x,y,yaw`` (or ``t,robot,x,y,qz,qw``, or ``qx,qy,qz,qw``) file; rows
    sorted by (robot, t).

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file.

    Returns
    -------
    PoseTracks
        Its poses, robots in order of first appearance, ``source`` the path.

    Raises
    ------
    PoseError
        Naming the file and line: a missing or repeated column, both ``yaw`` and ``qz``/``qw``
        or neither, one of ``qx``/``qy`` without the other, a non-number, a missing, NaN or
        infinite value, an empty robot name, or a quaternion whose components are all 0 or one
        beyond :data:`MAX_QUATERNION`; or a file that does not exist or cannot be read.
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    path = Path(path)
    header = csv_header(path, PoseError)
    for col in ("t", "robot", "x", "y"):
        if col not in header:
            raise PoseError(f"{path}: line 1: missing column '{col}' (expected t,robot,x,y,yaw)")
    twice = repeated_column(header)
    if twice is not None:
        raise PoseError(f"{path}: line 1: column '{twice[:40]}' appears twice")
    if "yaw" in header and ("qz" in header or "qw" in header):
        raise PoseError(f"{path}: line 1: give the heading as 'yaw' or as 'qz','qw', not both")
    if "yaw" in header:
        angles = ["yaw"]
    elif "qz" in header and "qw" in header:
        # a full quaternion's qx, qy are read, as a bag's are: dropping them misreads a tilted
        # or upside-down body (a motion-capture frame with z down has qz = qw = 0)
        full = "qx" in header or "qy" in header
        if full and not ("qx" in header and "qy" in header):
            given, missing = ("qx", "qy") if "qx" in header else ("qy", "qx")
            raise PoseError(
                f"{path}: line 1: a quaternion with '{given}' needs '{missing}' too (give "
                "qx,qy,qz,qw, or qz,qw alone for a planar one)"
            )
        angles = ["qx", "qy", "qz", "qw"] if full else ["qz", "qw"]
    else:
        raise PoseError(f"{path}: line 1: need a 'yaw' column or 'qz' and 'qw' columns")
    numeric = ["t", "x", "y", *angles]
    types = {c: pa.float64() for c in numeric} | {"robot": pa.string()}
    table = _read_arrow_csv(path, header, types, set(numeric))
    if table.num_rows == 0:
        return PoseTracks.empty(source=str(path))
    cols = {c: table.column(c).to_numpy(zero_copy_only=False) for c in numeric}
    for c in numeric:
        null = ~np.isfinite(cols[c])  # nulls arrive as NaN
        if null.any():
            row = int(np.argmax(null))
            raise PoseError(
                f"{path}: line {_line_of(path, row)}: column {c}: missing, NaN or infinite value"
            )
    robot = pc.dictionary_encode(pc.utf8_trim_whitespace(table.column("robot")).combine_chunks())
    names = [str(n) for n in robot.dictionary.to_pylist()]
    if "" in names:
        row = int(np.argmax(np.asarray(robot.indices) == names.index("")))
        raise PoseError(f"{path}: line {_line_of(path, row)}: empty robot name")
    if "yaw" in cols:
        yaw = cols["yaw"]
    else:
        quaternion = np.column_stack([cols[c] for c in angles])
        which = " or ".join(", ".join(angles).rsplit(", ", 1))
        far = far_quaternion(quaternion)
        if far.any():
            row = int(np.argmax(far))
            raise PoseError(
                f"{path}: line {_line_of(path, row)}: {which} beyond ±{MAX_QUATERNION:g} "
                "(a quaternion's components lie in [-1, 1])"
            )
        zero = (quaternion**2).sum(axis=1) < 1e-12
        if zero.any():
            row = int(np.argmax(zero))
            every = " = ".join(angles)
            raise PoseError(f"{path}: line {_line_of(path, row)}: {every} = 0 is no orientation")
        if "qx" in cols:
            yaw = yaw_from_quaternion(cols["qx"], cols["qy"], cols["qz"], cols["qw"])
        else:
            yaw = 2.0 * np.arctan2(cols["qz"], cols["qw"])
    return PoseTracks(
        tuple(names),
        cols["t"],
        np.asarray(robot.indices, dtype=np.int64),
        cols["x"],
        cols["y"],
        yaw,
        str(path),
    ).sorted()


def write_pose_csv(tracks: PoseTracks, path: str | Path) -> None:
    """Write ``t,robot,x,y,yaw`` rows (floats at full precision: reading back is exact).

    Parameters
    ----------
    tracks : PoseTracks
        The poses to write.
    path : str or pathlib.Path
        The CSV file to write (replaced if it exists).

    Raises
    ------
    PoseError
        The file cannot be written.
    """
    tr = tracks
    columns = {"t": tr.t, "robot": tr.robot, "x": tr.x, "y": tr.y, "yaw": tr.yaw}
    try:
        write_columns(path, columns, tr.robot, tr.robot_names)
    except OSError as exc:
        raise PoseError(f"{path}: cannot write ({exc})") from None
