"""Trajectory records ``t,robot,row,col,heading`` as columns of numpy arrays, with CSV input and
output. Reading validates every row against the scenario and reports the file, line and problem.
"""

from __future__ import annotations

import csv
import numbers
import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mirl.world.domain import PatrolDomain

__all__ = ["Trajectories", "TrajectoryError", "read_csv", "HEADER"]

HEADER = ("t", "robot", "row", "col", "heading")
# a time step at or beyond this is refused, not allocated: L's per-step arrays span the horizon
# (1 M steps = 23 days of robot time at 2 s a step; 8 MB per robot per array)
MAX_TIME = 1_000_000
_INTEGER = re.compile(r"[+-]?[0-9]+", re.ASCII)
_MAX_CELL = 2**62  # larger values are refused before numpy could overflow on them


class TrajectoryError(ValueError):
    """A trajectory file that cannot be used; the message names the file, line and problem."""



def _same_lateral(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Whether two records' lateral offsets are equal, NaN (a snapped pose) equal to NaN."""
    if a is None or b is None:
        return a is None and b is None
    return bool(np.array_equal(a, b, equal_nan=True))

@dataclass(frozen=True)
class Trajectories:
    """Observed (or true) states of several robots: one row per (time, robot).

    Rows are sorted by (t, robot).

    Parameters
    ----------
    robot_names : tuple of str
        The robots' names.
    t : ndarray of int, shape (n,)
        Time steps.
    robot : ndarray of int, shape (n,)
        Indices into ``robot_names``.
    row : ndarray of int, shape (n,)
        Cells' rows.
    col : ndarray of int, shape (n,)
        Cells' columns.
    heading : ndarray of int, shape (n,)
        Headings (0 east, 1 north, 2 west, 3 south).
    horizon : int
        The steps the record spans (times are below it).
    lateral : ndarray of shape (n,), optional
        Robot data only: what discretising a pose to its cell leaves over across the heading —
        the signed distance (cells, left of the heading positive) of the measured position from
        the centre line of its cell along its discretised heading; NaN where unknown. It is the
        evidence of a robot that veers (a weak wheel) that the grid state discards
        (docs/design.md, "Fault verdicts").
    off_pace : str, optional
        Robot data only: why the step the poses were read at may be no healthy robot's pace
        (:func:`~mirl.observations.discretise.off_pace`), empty when nothing says so; None
        where nothing tells (grid states). The fault verdicts' model check reads it.
    tracker_interval : float, optional
        Robot data only: the interval (s) of the sparse tracker whose poses the record was
        read at one a step, where the auto step chose it
        (:func:`~mirl.observations.discretise.auto_step_seconds`, ``"poses"``); None
        otherwise. The step is then the tracker's and may be no robot's pace, which the
        model check asks of the robots' moves
        (:func:`~mirl.learning.verdicts.record_off_pace`).
    step_given : float, optional
        Robot data only: the step (s) the record was read at where it was given, not chosen by
        the auto step; None otherwise. A given step is the robots' pace by the user's word,
        which the model check asks of the robots' moves as it asks the tracker's interval.

        .. versionchanged:: 0.2.0
           ``step_given`` is new.
    """

    robot_names: tuple[str, ...]
    t: np.ndarray
    robot: np.ndarray
    row: np.ndarray
    col: np.ndarray
    heading: np.ndarray
    horizon: int  # number of time steps the record spans (observed or not): t in [0, horizon)
    lateral: np.ndarray | None = None
    off_pace: str | None = None
    tracker_interval: float | None = None
    step_given: float | None = None

    def __post_init__(self) -> None:
        # A record made in Python, not read from a file, is checked here as the readers check
        # theirs: a row of a robot or a time outside the record would otherwise be dropped
        # without a word (learned as a robot never seen) or fail deep inside numpy. Lists are
        # taken as arrays; fractional numbers are refused rather than truncated.
        names = self.robot_names
        if isinstance(names, str) or not all(isinstance(n, str) for n in names):
            raise TrajectoryError(f"robot_names must be a sequence of str, got {names!r}")
        object.__setattr__(self, "robot_names", tuple(names))
        horizon = self.horizon
        if isinstance(horizon, bool) or not isinstance(horizon, numbers.Integral):
            raise TrajectoryError(f"horizon must be an integer, got {horizon!r}")
        if not 0 <= horizon <= MAX_TIME:
            raise TrajectoryError(f"horizon must be in [0, {MAX_TIME}] steps, got {horizon}")
        object.__setattr__(self, "horizon", int(horizon))
        n = None
        for name in HEADER:
            column = np.asarray(getattr(self, name))
            if column.size == 0:  # np.array([]) is float: an empty column of any type is empty
                column = column.astype(np.int64)
            if column.ndim != 1 or column.dtype.kind not in "iu":
                got = f"shape {column.shape}" if column.ndim != 1 else f"dtype {column.dtype}"
                raise TrajectoryError(f"{name} must be a 1-D array of integers, got {got}")
            if n is not None and len(column) != n:
                raise TrajectoryError(f"{name} has {len(column)} rows, t has {n}")
            n = len(column)
            object.__setattr__(self, name, column)
        for name, high in (("t", self.horizon), ("robot", len(self.robot_names)), ("heading", 4)):
            column = getattr(self, name)
            bad = np.flatnonzero((column < 0) | (column >= high))
            if bad.size:
                i = int(bad[0])
                raise TrajectoryError(
                    f"row {i}: {name} {int(column[i])} is not in [0, {high})"
                    + (f" (robot_names: {', '.join(self.robot_names)})" if name == "robot" else "")
                )
        if self.lateral is not None:
            lateral = np.asarray(self.lateral, dtype=float)
            if lateral.shape != (n,):
                raise TrajectoryError(f"lateral must have shape ({n},), got {lateral.shape}")
            object.__setattr__(self, "lateral", lateral)

    def __eq__(self, other: object) -> bool:
        # by value, as a record read back from its CSV equals the one written; the dataclass's
        # own __eq__ compares the arrays as a tuple and raises numpy's "truth value of an array
        # is ambiguous"
        if not isinstance(other, Trajectories):
            return NotImplemented
        arrays = ("t", "robot", "row", "col", "heading")
        return (
            (self.robot_names, self.horizon, self.off_pace, self.tracker_interval, self.step_given)
            == (other.robot_names, other.horizon, other.off_pace, other.tracker_interval,
                other.step_given)
            and all(np.array_equal(getattr(self, a), getattr(other, a)) for a in arrays)
            and _same_lateral(self.lateral, other.lateral)
        )  # fmt: skip

    def __len__(self) -> int:
        return len(self.t)

    def states(self, domain: PatrolDomain) -> np.ndarray:
        """The state index of every row.

        Parameters
        ----------
        domain : PatrolDomain
            The domain the cells are states of.

        Returns
        -------
        ndarray of int, shape (n,)
            State indices; -1 where a row is not a patroller state.
        """
        return domain.state_index(self.row, self.col, self.heading)

    def for_robot(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """One robot's rows, sorted by time.

        Parameters
        ----------
        index : int
            The robot's index.

        Returns
        -------
        times : ndarray of int
            Its time steps.
        rows : ndarray of int
            The indices of its rows.
        """
        sel = self.robot == index
        return self.t[sel], np.flatnonzero(sel)

    def state_series(self, domain: PatrolDomain, index: int) -> np.ndarray:
        """One robot's state per time step.

        Parameters
        ----------
        domain : PatrolDomain
            The domain the cells are states of.
        index : int
            The robot's index.

        Returns
        -------
        ndarray of int, shape (horizon,)
            The state at every step; -1 where not observed.
        """
        out = np.full(self.horizon, -1, dtype=int)
        t, rows = self.for_robot(index)
        out[t] = self.states(domain)[rows]
        return out

    def lateral_series(self, index: int) -> np.ndarray | None:
        """One robot's lateral offset per time step.

        Parameters
        ----------
        index : int
            The robot's index.

        Returns
        -------
        ndarray of shape (horizon,), or None
            The offset at every step (NaN where unknown), or None when the record has none.
        """
        if self.lateral is None:
            return None
        out = np.full(self.horizon, np.nan)
        t, rows = self.for_robot(index)
        out[t] = self.lateral[rows]
        return out

    def select(self, mask: np.ndarray) -> Trajectories:
        """The rows where ``mask`` holds.

        Parameters
        ----------
        mask : ndarray of bool, shape (n,)
            Which rows to keep.

        Returns
        -------
        Trajectories
            The same robots and horizon, fewer rows.
        """
        return Trajectories(
            self.robot_names,
            self.t[mask],
            self.robot[mask],
            self.row[mask],
            self.col[mask],
            self.heading[mask],
            self.horizon,
            None if self.lateral is None else self.lateral[mask],
            self.off_pace,
            self.tracker_interval,
            self.step_given,
        )

    def truncate(self, steps: int) -> Trajectories:
        """The record's first ``steps`` time steps.

        Parameters
        ----------
        steps : int
            The new horizon.

        Returns
        -------
        Trajectories
            The rows before ``steps``, horizon ``steps``.
        """
        out = self.select(self.t < steps)
        return replace(out, horizon=steps)

    @classmethod
    def from_states(
        cls,
        domain: PatrolDomain,
        robot_names: tuple[str, ...],
        states: np.ndarray,
        t0: int = 0,
        lateral: np.ndarray | None = None,
    ) -> Trajectories:
        """From a (T, N) array of state indices, -1 meaning unobserved.

        Parameters
        ----------
        domain : PatrolDomain
            The domain the states are of.
        robot_names : tuple of str
            The N robots' names.
        states : ndarray of int, shape (T, N)
            A state per step and robot; -1 where unobserved.
        t0 : int, default 0
            The time of the first row of ``states``.
        lateral : ndarray of shape (T, N), optional
            The lateral offsets that go with the states.

        Returns
        -------
        Trajectories
            The observed rows, horizon ``T + t0``.

        Raises
        ------
        TrajectoryError
            ``states`` not a (T, N) array of integers in [-1, S).
        """
        states = np.asarray(states)
        if states.ndim != 2 or (states.size and states.dtype.kind not in "iu"):
            raise TrajectoryError(
                f"states must be a (T, N) array of integers, got shape {states.shape} and "
                f"dtype {states.dtype}"
            )
        bad = (states < -1) | (states >= domain.n_states)
        if bad.any():  # -5 would be read as unobserved, 9999 fail inside numpy
            tt, rr = np.argwhere(bad)[0]
            raise TrajectoryError(
                f"states[{tt}, {rr}] = {states[tt, rr]} is not a state index in "
                f"[0, {domain.n_states}) or -1 (unobserved)"
            )
        states = states.astype(np.int64, copy=False)
        tt, rr = np.nonzero(states >= 0)
        rch = domain.states[states[tt, rr]]
        lat = None if lateral is None else np.asarray(lateral, dtype=float)[tt, rr]
        return cls(
            robot_names, tt + t0, rr, rch[:, 0], rch[:, 1], rch[:, 2], states.shape[0] + t0, lat
        )

    def to_csv(self, path: str | Path) -> None:
        """Write ``t,robot,row,col,heading`` rows (pyarrow, vectorised).

        Parameters
        ----------
        path : str or Path
            The CSV file to write.
        """
        from mirl.observations._csv import write_columns

        columns = {h: getattr(self, h) for h in HEADER}
        write_columns(path, columns, self.robot, self.robot_names)


def read_csv(
    path: str | Path,
    domain: PatrolDomain,
    robot_names: tuple[str, ...],
    horizon: int | None = None,
) -> Trajectories:
    """Read and validate a ``t,robot,row,col,heading`` file.

    Vectorised: ``pyarrow.csv`` parses the columns (one thread) and the checks run on whole
    arrays; a file pyarrow will not parse as clean integers goes to the row-by-row reader, whose
    messages (file, line, problem) are the reference. Measured on a 50 MB file (3.9 M rows,
    ``benchmarks/bench_robot_data.py``): see docs/design.md, "Robot data in".

    Parameters
    ----------
    path : str or Path
        The CSV file.
    domain : PatrolDomain
        The domain every row must be a state of.
    robot_names : tuple of str
        The robots the file may name.
    horizon : int, optional
        The record's horizon; the last time + 1 by default.

    Returns
    -------
    Trajectories
        The rows, sorted by (t, robot).

    Raises
    ------
    TrajectoryError
        A missing column, a non-integer cell, a negative time, a state that is not a hallway
        cell with heading 0–3, an unknown robot or a duplicate (t, robot).
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    from mirl.observations._csv import arrow_read, csv_header, data_line_numbers

    path = Path(path)
    robot_names = tuple(robot_names)
    try:
        header = csv_header(path, TrajectoryError)
    except TrajectoryError:  # missing, unreadable or empty: the reference's message
        return _read_csv_python(path, domain, robot_names, horizon)
    if any(h not in header for h in HEADER) or len(set(header)) != len(header):
        return _read_csv_python(path, domain, robot_names, horizon)
    if _maybe_hex(path):  # pyarrow reads "0x10" as 16; the reference refuses it, naming the line
        return _read_csv_python(path, domain, robot_names, horizon)
    types = {h: pa.int64() for h in HEADER} | {"robot": pa.string()}
    try:
        table = arrow_read(path, header, types)
    except (pa.ArrowInvalid, pa.ArrowKeyError, UnicodeDecodeError):
        return _read_csv_python(path, domain, robot_names, horizon)
    if any(table.column(h).null_count for h in HEADER):  # empty cells: the reference decides
        return _read_csv_python(path, domain, robot_names, horizon)
    t, row, col, heading = (
        table.column(h).to_numpy().astype(np.int64, copy=False)
        for h in ("t", "row", "col", "heading")
    )
    robot_col = pc.dictionary_encode(
        pc.utf8_trim_whitespace(table.column("robot").combine_chunks())
    )
    names = [str(n) for n in robot_col.dictionary.to_pylist()]
    lut = np.array([robot_names.index(n) if n in robot_names else -1 for n in names] or [-1])
    robot = lut[np.asarray(robot_col.indices, dtype=np.int64)] if len(t) else t.copy()

    # per-row checks in the row-by-row reader's order: robot, negative time, state
    state = domain.state_index(row, col, heading) if len(t) else t
    bad_robot, bad_t, bad_state = robot < 0, (t < 0) | (t >= MAX_TIME), np.asarray(state) < 0
    bad = bad_robot | bad_t | bad_state
    if bad.any():
        i = int(np.argmax(bad))
        line = int(data_line_numbers(path)[i])
        if bad_robot[i]:
            name = _shown(names[int(np.asarray(robot_col.indices)[i])])
            known = ", ".join(robot_names)
            raise TrajectoryError(
                f"{path}: line {line}: robot '{name}' is not in the scenario ({known})"
            )
        if bad_t[i]:
            raise TrajectoryError(f"{path}: line {line}: {_time_problem(int(t[i]))}")
        what = _state_problem(domain, int(row[i]), int(col[i]), int(heading[i]))
        raise TrajectoryError(f"{path}: line {line}: {what}")
    arr = np.column_stack([t, robot, row, col, heading])
    return _sorted_checked(
        path, arr, lambda i: int(data_line_numbers(path)[i]), robot_names, horizon
    )


# a cell that starts with 0x after blanks, a sign or an opening quote, on any line ending:
# pyarrow's integer parser reads it as hexadecimal, quoted or not (0x10 and "0x10" are 16)
_HEX_CELL = re.compile(rb'(?:^|[,\r])[ \t]*"?[ \t]*[+-]?0[xX]', re.M)


def _maybe_hex(path: Path) -> bool:
    """Whether some cell of the file may be a hexadecimal number ("0x10"), which pyarrow's
    integer parser accepts and the row-by-row reader refuses (a robot named "0x1" sends the
    file to that reader too, which reads it as it should)."""
    with open(path, "rb") as f:
        data = f.read()
    # a substring search first: the regular expression over a large file costs half a read
    return (b"0x" in data or b"0X" in data) and _HEX_CELL.search(data) is not None


def _shown(text: str, limit: int = 40) -> str:
    """A cell's text as quoted in a one-line message: at most ``limit`` characters, control
    characters escaped."""
    shown = text[:limit].encode("unicode_escape").decode("ascii")
    return shown if len(text) <= limit else f"{shown}... ({len(text)} characters)"


def _time_problem(t: int) -> str:
    if t < 0:
        return f"negative time {t}"
    return f"time {t} is beyond the limit of {MAX_TIME} steps (t must be < {MAX_TIME})"


def _state_problem(domain: PatrolDomain, r: int, c: int, h: int) -> str:
    """Why (r, c, h) is not a patroller state."""
    if 0 <= r < domain.map.shape[0] and 0 <= c < domain.map.shape[1] and domain.cell_lut[r, c] >= 0:
        return f"heading {h} is not 0-3"
    return f"cell ({r},{c}) is not a hallway cell (a wall or off the map)"


def _sorted_checked(path, arr: np.ndarray, line_of, robot_names, horizon) -> Trajectories:
    """Rows (t, robot, row, col, heading) in file order -> sorted trajectories; a duplicate
    (t, robot) names the line (``line_of(file row)``) of its second occurrence."""
    order = np.lexsort((arr[:, 1], arr[:, 0]))
    arr = arr[order]
    dup = np.flatnonzero((np.diff(arr[:, 0]) == 0) & (np.diff(arr[:, 1]) == 0))
    if dup.size:
        raise TrajectoryError(
            f"{path}: line {line_of(order[dup[0] + 1])}: duplicate row for robot "
            f"{robot_names[arr[dup[0], 1]]} at t={arr[dup[0], 0]}"
        )
    last = int(arr[:, 0].max()) + 1 if len(arr) else 0
    if horizon is None:
        horizon = last
    elif horizon < last:
        raise TrajectoryError(f"{path}: time {last - 1} is beyond the horizon {horizon}")
    return Trajectories(robot_names, arr[:, 0], arr[:, 1], arr[:, 2], arr[:, 3], arr[:, 4], horizon)


def _read_csv_python(
    path: str | Path,
    domain: PatrolDomain,
    robot_names: tuple[str, ...],
    horizon: int | None = None,
) -> Trajectories:
    """The row-by-row reader (csv module): the reference for :func:`read_csv`'s messages, and
    its fallback for any file pyarrow will not parse (non-integers, short rows, spaces...)."""
    path = Path(path)
    try:
        fh = open(path, newline="", encoding="utf-8-sig")  # a UTF-8 BOM is accepted
    except OSError as exc:
        raise TrajectoryError(f"{path}: cannot read ({exc.strerror or exc})") from None
    reader = csv.reader(fh)
    try:
        with fh:
            return _parse_rows(path, reader, domain, robot_names, horizon)
    except UnicodeDecodeError as exc:
        raise TrajectoryError(
            f"{path}: not UTF-8 text (byte 0x{exc.object[exc.start]:02x} cannot be decoded)"
        ) from None
    except csv.Error as exc:
        raise TrajectoryError(f"{path}: line {reader.line_num}: {exc}") from None


def _parse_rows(path: Path, reader, domain, robot_names, horizon) -> Trajectories:
    """The row-by-row checks of :func:`_read_csv_python` on an open ``csv.reader``."""
    header = next(reader, None)
    if header is None:
        raise TrajectoryError(f"{path}: file is empty (expected header {','.join(HEADER)})")
    header = [h.strip() for h in header]
    missing = [h for h in HEADER if h not in header]
    if missing:
        raise TrajectoryError(f"{path}: line 1: missing column '{missing[0]}'")
    from mirl.observations._csv import repeated_column

    twice = repeated_column(header)
    if twice is not None:
        raise TrajectoryError(f"{path}: line 1: column '{_shown(twice)}' appears twice")
    idx = [header.index(h) for h in HEADER]
    rows: list[tuple[int, int, int, int, int]] = []
    lines: list[int] = []
    for lineno, rec in enumerate(reader, start=2):
        if not rec or all(not x.strip() for x in rec):
            continue
        if len(rec) != len(header):  # a longer row has cells no column names
            raise TrajectoryError(
                f"{path}: line {lineno}: expected {len(header)} cells, got {len(rec)}"
            )
        vals = [rec[i].strip() for i in idx]
        name = vals[1]
        if name not in robot_names:
            known = ", ".join(robot_names)
            raise TrajectoryError(
                f"{path}: line {lineno}: robot '{_shown(name)}' is not in the scenario ({known})"
            )
        numbers = (0, 2, 3, 4)  # the integer columns, by their place in HEADER
        bad = next((i for i in numbers if not _is_int(vals[i])), None)
        if bad is not None:  # decimal only: no 0x10, 6_0 or non-ASCII digits
            raise TrajectoryError(
                f"{path}: line {lineno}: column {HEADER[bad]}: '{_shown(vals[bad])}' is not an "
                "integer"
            )
        long = next((i for i in numbers if len(vals[i]) > 24), None)
        if long is not None:  # past int64 anyway (and int() refuses 4 300 digits)
            raise TrajectoryError(
                f"{path}: line {lineno}: column {HEADER[long]}: '{_shown(vals[long])}' is too large"
            )
        t, r, c, h = (int(vals[i]) for i in numbers)
        cells = zip(numbers[1:], (r, c, h), strict=True)
        big = next((i for i, v in cells if abs(v) >= _MAX_CELL), None)
        if big is not None:
            raise TrajectoryError(
                f"{path}: line {lineno}: column {HEADER[big]}: {int(vals[big])} is too large"
            )
        if not 0 <= t < MAX_TIME:
            raise TrajectoryError(f"{path}: line {lineno}: {_time_problem(t)}")
        if domain.state_index(r, c, h) < 0:
            what = _state_problem(domain, r, c, h)
            raise TrajectoryError(f"{path}: line {lineno}: {what}")
        rows.append((t, robot_names.index(name), r, c, h))
        lines.append(lineno)
    arr = np.asarray(rows, dtype=int).reshape(-1, 5)
    return _sorted_checked(path, arr, lines.__getitem__, robot_names, horizon)


def _is_int(text: str) -> bool:
    """Plain ASCII digits with an optional sign, as pyarrow parses them: Python's int() would
    also take ``6_0`` (60) and non-ASCII digits, which no robot log means as numbers."""
    return _INTEGER.fullmatch(text) is not None
