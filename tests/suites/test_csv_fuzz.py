"""Issue 13: the grid observation CSV reader on hostile input — a BOM is accepted; values too
large, a giant field, undecodable bytes and a row far in the future are one-line
TrajectoryErrors naming the file; any bytes at all give Trajectories or TrajectoryError."""

from __future__ import annotations

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mirl.observations.trajectories import MAX_TIME, Trajectories, TrajectoryError, read_csv
from mirl.world.scenario import load_scenario

NAMES = ("I", "J")
GOOD = "t,robot,row,col,heading\n0,I,0,8,2\n0,J,16,8,2\n"


@pytest.fixture(scope="module")
def domain():
    return load_scenario("boyd2").domain


def _write(tmp_path, data: bytes, name="obs.csv"):
    p = tmp_path / name
    p.write_bytes(data)
    return p


def test_utf8_bom_is_accepted(tmp_path, domain):
    tr = read_csv(_write(tmp_path, b"\xef\xbb\xbf" + GOOD.encode()), domain, NAMES)
    assert len(tr) == 2 and tr.horizon == 1


@pytest.mark.parametrize(
    "tail, expected",
    [
        (
            "1,I,0,99999999999999999999999,2\n",
            "line 4: column col: 99999999999999999999999 is too large",
        ),
        ("1,I,0,7,-99999999999999999999999\n", "is too large"),
        (f"{10**12},I,0,7,2\n", f"line 4: time {10**12} is beyond the limit of {MAX_TIME}"),
        (f"{MAX_TIME},I,0,7,2\n", "is beyond the limit"),
        ("1," + "I" * 200_000 + ",0,7,2\n", "line 4: robot 'IIII"),
        ("1,I," + "9" * 10_000 + ",7,2\n", "(10000 characters)' is too large"),
        ("1,I\x00,0,7,2\n", "robot 'I\\x00' is not in the scenario"),
    ],
)
def test_hostile_values_are_one_line_errors(tmp_path, domain, tail, expected):
    path = _write(tmp_path, (GOOD + tail).encode())
    with pytest.raises(TrajectoryError) as err:
        read_csv(path, domain, NAMES)
    msg = str(err.value)
    assert msg.startswith(str(path)) and expected in msg
    assert "\n" not in msg and len(msg) < 300


def test_giant_field_in_the_row_by_row_reader(tmp_path, domain):
    from mirl.observations.trajectories import _read_csv_python

    path = _write(tmp_path, (GOOD + '1,"' + "I" * 200_000 + '",0,7,2\n').encode())
    with pytest.raises(TrajectoryError, match=r"obs\.csv: line 4: field larger than field limit"):
        _read_csv_python(path, domain, NAMES)
    with pytest.raises(TrajectoryError, match=r"obs\.csv: line 4: robot 'IIII"):
        read_csv(path, domain, NAMES)


def test_far_future_row_does_not_allocate(tmp_path, domain):
    # one row at the limit - 1 is legal and costs a few MB, not gigabytes
    tr = read_csv(_write(tmp_path, (GOOD + f"{MAX_TIME - 1},I,0,7,2\n").encode()), domain, NAMES)
    assert tr.horizon == MAX_TIME


def test_undecodable_bytes_name_the_file(tmp_path, domain):
    path = _write(tmp_path, GOOD.encode() + b"1,\xff\xfe,0,7,2\n")
    with pytest.raises(TrajectoryError, match=r"obs\.csv: not UTF-8 text"):
        read_csv(path, domain, NAMES)


@settings(
    max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(
    data=st.one_of(
        st.binary(max_size=300),
        st.lists(
            st.sampled_from(
                [
                    "t,robot,row,col,heading\n",
                    "0,I,0,8,2\n",
                    "1,J,16,7,2\n",
                    ",",
                    '"',
                    "\r\n",
                    "\xef\xbb\xbf",
                    "-1",
                    "99999999999999999999",
                    "I",
                    " ",
                    "\x00",
                    "\xff",
                    "1e3",
                    "0,I,0,7,5\n",
                    "3,I,0,7,2\n",
                ]
            ),
            max_size=30,
        ).map(lambda parts: "".join(parts).encode("utf-8", "surrogateescape")),
    )
)
def test_any_bytes_give_trajectories_or_trajectory_error(tmp_path_factory, domain, data):
    path = tmp_path_factory.mktemp("fuzz") / "f.csv"
    path.write_bytes(data)
    try:
        tr = read_csv(path, domain, NAMES)
    except TrajectoryError as exc:
        assert "\n" not in str(exc) and str(exc).startswith(str(path))
    else:
        assert isinstance(tr, Trajectories) and tr.horizon <= MAX_TIME
