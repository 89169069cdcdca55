"""Trajectory CSV files: round trip, and every reading error names the file and the line."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from mirl.observations.trajectories import HEADER, Trajectories, TrajectoryError, read_csv
from mirl.simulation.grid import simulate
from mirl.world.scenario import load_scenario

NAMES = ("I", "J")


@pytest.fixture(scope="module")
def scenario():
    return load_scenario("boyd2")


@pytest.fixture(scope="module")
def domain(scenario):
    return scenario.domain


def arrays(tr: Trajectories):
    return [tr.t, tr.robot, tr.row, tr.col, tr.heading]


def assert_same(a: Trajectories, b: Trajectories) -> None:
    assert a.robot_names == b.robot_names
    assert a.horizon == b.horizon
    for x, y in zip(arrays(a), arrays(b), strict=True):
        np.testing.assert_array_equal(x, y)


@pytest.mark.parametrize("degree", [0.14, 0.5, 1.0])
def test_round_trip(tmp_path, scenario, domain, degree):
    res = simulate(scenario, 400, seed=4, observability=degree, heading_noise=0.05)
    for name, traj in (("truth", res.truth), ("obs", res.observations)):
        path = tmp_path / f"{name}.csv"
        traj.to_csv(path)
        assert path.read_text().splitlines()[0] == ",".join(HEADER)
        back = read_csv(path, domain, NAMES, horizon=traj.horizon)
        assert_same(back, traj)
        # the state indices survive too
        np.testing.assert_array_equal(back.states(domain), traj.states(domain))


def test_round_trip_default_horizon_and_order(tmp_path, domain):
    # rows out of order, extra column, spaces, blank line: read back sorted by (t, robot)
    path = tmp_path / "x.csv"
    path.write_text(
        "robot,t,heading,row,col,note\nJ, 3, 1, 16, 1, a\n\nI,0,2,0,4,b\nJ,0,0,16,5,c\n"
    )
    tr = read_csv(path, domain, NAMES)
    assert tr.horizon == 4
    assert tr.t.tolist() == [0, 0, 3]
    assert tr.robot.tolist() == [0, 1, 1]
    assert list(zip(tr.row.tolist(), tr.col.tolist(), tr.heading.tolist(), strict=True)) == [
        (0, 4, 2),
        (16, 5, 0),
        (16, 1, 1),
    ]
    series = tr.state_series(domain, 1)
    assert series.shape == (4,)
    assert series[1] == series[2] == -1
    assert series[3] == domain.state_index(16, 1, 1)
    out = tmp_path / "y.csv"
    tr.to_csv(out)
    assert_same(read_csv(out, domain, NAMES), tr)


def test_header_only_file(tmp_path, domain):
    path = tmp_path / "h.csv"
    path.write_text("t,robot,row,col,heading\n")
    tr = read_csv(path, domain, NAMES, horizon=10)
    assert len(tr) == 0 and tr.horizon == 10


GOOD = "t,robot,row,col,heading\n0,I,0,8,2\n0,J,16,8,2\n"


@pytest.mark.parametrize(
    "text, needle",
    [
        ("t,robot,row,heading\n0,I,0,2\n", "line 1: missing column 'col'"),
        (GOOD + "1,I,zero,7,2\n", "line 4: column row: 'zero' is not an integer"),
        (GOOD + "1,I,0,7.5,2\n", "line 4: column col: '7.5' is not an integer"),
        # pyarrow's integer parser reads hexadecimal; a grid CSV's cells are decimal
        (GOOD + "0x10,I,0,7,2\n", "line 4: column t: '0x10' is not an integer"),
        (GOOD + "1,I, 0X0,7,2\n", "line 4: column row: '0X0' is not an integer"),
        # quoted, after a sign or on a line ended by a lone CR, pyarrow read 16 as well
        (GOOD + '"0x10",I,0,7,2\n', "line 4: column t: '0x10' is not an integer"),
        (GOOD + '1,I,0," +0x7",2\n', "line 4: column col: '+0x7' is not an integer"),
        (GOOD.replace("\n", "\r") + "0x10,I,0,7,2\r", "line 4: column t: '0x10' is not"),
        # other bases and forms Python's int() takes are not decimal either
        (GOOD + "0b1,I,0,7,2\n", "line 4: column t: '0b1' is not an integer"),
        (GOOD + "0o7,I,0,7,2\n", "line 4: column t: '0o7' is not an integer"),
        (GOOD + "1,I,0,7,0_2\n", "line 4: column heading: '0_2' is not an integer"),
        (GOOD + "1,I,3,4,2\n", "line 4: cell (3,4) is not a hallway cell"),
        (GOOD + "1,I,0,0,2\n", "line 4: cell (0,0)"),  # L's room
        (GOOD + "1,I,40,1,2\n", "line 4: cell (40,1)"),  # off the map
        (GOOD + "1,I,0,7,4\n", "line 4: heading 4 is not 0-3"),
        (GOOD + "1,I,0,7,-1\n", "line 4: heading -1"),
        (GOOD + "1,K,0,7,2\n", "line 4: robot 'K' is not in the scenario"),
        (GOOD + "1,I,0,7,2\n0,J,16,7,2\n", "line 5: duplicate row for robot J at t=0"),
        (GOOD + "-1,I,0,7,2\n", "line 4: negative time"),
        (GOOD + "1,I,0\n", "line 4: expected 5 cells"),
        ("", "file is empty"),
    ],
    ids=[
        "missing-column",
        "non-integer",
        "non-integer-float",
        "hexadecimal",
        "hexadecimal-spaced",
        "hexadecimal-quoted",
        "hexadecimal-quoted-signed",
        "hexadecimal-cr-lines",
        "binary",
        "octal",
        "underscore",
        "wall",
        "room",
        "off-map",
        "heading-4",
        "heading-negative",
        "unknown-robot",
        "duplicate",
        "negative-time",
        "short-row",
        "empty",
    ],
)
def test_errors_name_file_and_line(tmp_path, domain, text, needle):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(TrajectoryError) as info:
        read_csv(path, domain, NAMES)
    msg = str(info.value)
    assert msg.startswith(f"{path}: ")
    assert needle in msg
    assert "\n" not in msg


def test_decimal_cells_read_as_before(tmp_path, domain):
    """Refusing other bases leaves every decimal form read as it was: a sign, leading zeros,
    blanks and quotes around the digits."""
    path = tmp_path / "ok.csv"
    path.write_text(GOOD + '+1,I, 0 ,"07",+2\n"2", I ,-0,006,02\n')
    tr = read_csv(path, domain, NAMES)
    rows = zip(*(a.tolist() for a in (tr.t, tr.robot, tr.row, tr.col, tr.heading)), strict=True)
    assert list(rows) == [(0, 0, 0, 8, 2), (0, 1, 16, 8, 2), (1, 0, 0, 7, 2), (2, 0, 0, 6, 2)]


def test_beyond_horizon_and_missing_file(tmp_path, domain):
    path = tmp_path / "ok.csv"
    path.write_text(GOOD + "7,I,0,7,2\n")
    with pytest.raises(TrajectoryError, match="beyond the horizon 5"):
        read_csv(path, domain, NAMES, horizon=5)
    missing = tmp_path / "absent.csv"
    with pytest.raises(TrajectoryError, match=str(missing)):
        read_csv(missing, domain, NAMES)


def test_trajectory_helpers(domain):
    states = np.array([[0, -1], [1, 5], [-1, 6]])
    tr = Trajectories.from_states(domain, NAMES, states)
    assert len(tr) == 4 and tr.horizon == 3
    assert tr.state_series(domain, 0).tolist() == [0, 1, -1]
    assert tr.state_series(domain, 1).tolist() == [-1, 5, 6]
    short = tr.truncate(2)
    assert short.horizon == 2 and short.t.tolist() == [0, 1, 1]
    times, rows = tr.for_robot(1)
    assert times.tolist() == [1, 2] and len(rows) == 2


def test_error_is_value_error():
    assert issubclass(TrajectoryError, ValueError)


def _made(**changes):
    """A two-row record made in Python, with ``changes`` to its fields."""
    fields = dict(robot_names=NAMES, t=[0, 1], robot=[0, 1], row=[0, 0], col=[4, 3],
                  heading=[2, 2], horizon=3)  # fmt: skip
    return Trajectories(**(fields | changes))


def test_a_record_made_in_python_takes_lists_as_arrays(domain):
    tr = _made()
    assert tr.t.dtype.kind == "i"
    assert tr.state_series(domain, 1).tolist() == [-1, domain.state_index(0, 3, 2), -1]
    empty = _made(t=[], robot=[], row=[], col=[], heading=[])  # np.array([]) is float
    assert len(empty) == 0 and empty.t.dtype.kind == "i"


@pytest.mark.parametrize(
    ("changes", "needle"),
    [
        ({"robot": [0, 2]}, r"row 1: robot 2 is not in \[0, 2\) \(robot_names: I, J\)"),
        ({"t": [0, 3]}, r"row 1: t 3 is not in \[0, 3\)"),
        ({"t": [-1, 1]}, r"row 0: t -1 is not in"),
        ({"heading": [2, 7]}, r"row 1: heading 7 is not in \[0, 4\)"),
        ({"col": [4.0, 3.5]}, "col must be a 1-D array of integers, got dtype float64"),
        ({"row": [[0, 0]]}, r"row must be a 1-D array of integers, got shape \(1, 2\)"),
        ({"heading": [2]}, "heading has 1 rows, t has 2"),
        ({"horizon": 3.0}, "horizon must be an integer, got 3.0"),
        ({"horizon": 10**9}, r"horizon must be in \[0, 1000000\]"),
        ({"robot_names": "IJ"}, "robot_names must be a sequence of str"),
        ({"lateral": [0.1]}, r"lateral must have shape \(2,\)"),
    ],
)
def test_a_record_made_in_python_is_checked_as_a_file_is(changes, needle):
    """A robot index or a time outside the record was dropped without a word (the robot then
    learned as never seen) or failed deep inside numpy; each is now named."""
    with pytest.raises(TrajectoryError, match=needle):
        _made(**changes)


def test_from_states_refuses_what_is_no_state_index(domain):
    for states, needle in [
        (np.array([[0, -5]]), r"states\[0, 1\] = -5 is not a state index"),
        (np.array([[0, domain.n_states]]), "is not a state index"),
        (np.array([[0.0, 1.5]]), "must be a \\(T, N\\) array of integers"),
        (np.array([0, 1]), "must be a \\(T, N\\) array of integers"),
    ]:
        with pytest.raises(TrajectoryError, match=needle):
            Trajectories.from_states(domain, NAMES, states)


def test_records_compare_by_value():
    """== compared the arrays as a tuple and raised numpy's "truth value is ambiguous"."""
    import copy

    obs = simulate(load_scenario("boyd2"), 50, seed=1).observations
    assert obs == copy.deepcopy(obs) and not obs != copy.deepcopy(obs)
    assert obs != obs.truncate(10)  # fewer rows and a shorter horizon
    moved = copy.deepcopy(obs)
    moved.row[0] += 1
    assert obs != moved and obs != 3
    with_nan = dataclasses.replace(obs, lateral=np.full(len(obs), np.nan))
    assert with_nan == dataclasses.replace(obs, lateral=np.full(len(obs), np.nan))
    assert with_nan != obs  # offsets against none
