"""The options layer's machinery: constraints, declared fields checked when an options type is
made, one error naming the option, the nearest known name for a typo, flags' text parsed by the
same declaration."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mirl._registry import Registry
from mirl._validation import (
    SEED,
    Boolean,
    Instance,
    Interval,
    OneOf,
    OptionError,
    Options,
    Satisfies,
    check_argument,
    option,
    parse_number,
    same_option,
    unknown_name,
)


class Toy(Options):
    """An options type of every kind of field."""

    count: int = option(Interval(int, 1, 10), default=3, doc="a count", flag="--count")
    share: float | None = option(Interval(float, 0.0, 1.0), None, default=None, doc="a share")
    rate: float = option(Interval(float, 0.0, None, open_low=True), default=1.0, doc="rate")
    colour: str = option(
        OneOf(("red", "green", "blue"), kind="colour"), default="red", doc="a colour"
    )
    on: bool = option(Boolean(), default=True, doc="a switch", flag="--off")
    table: dict | None = option(Instance(dict, "a dict"), None, default=None, doc="a dict")
    even: str = option(
        Satisfies(lambda s: len(s) % 2 == 0, "an even-length text"), default="", doc="even"
    )

    def _check(self) -> None:
        if self.share is not None and self.count > 5:
            raise self.refuse("share", f"needs `count` at most 5, got {self.count}")


class Passing(Options):
    colour: str = same_option(Toy, "colour")


def test_defaults_and_the_declaration():
    toy = Toy()
    assert (toy.count, toy.share, toy.colour, toy.on) == (3, None, "red", True)
    assert Toy.default("count") == 3 and Toy.spec("count").flag == "--count"
    assert Toy.spec("colour").choices == ("red", "green", "blue")
    assert toy.changed() == {} and Toy(count=4).changed() == {"count": 4}
    assert list(toy.to_dict()) == list(Toy.__options__)


@pytest.mark.parametrize(
    ("values", "needle"),
    [
        ({"count": 0}, "`count` must be an integer in [1, 10], got 0"),
        ({"count": 2.0}, "`count` must be an integer in [1, 10], got 2.0"),
        ({"count": True}, "`count` must be an integer in [1, 10], got True"),
        ({"share": 1.5}, "`share` must be a number in [0, 1] or None, got 1.5"),
        ({"share": math.nan}, "`share` must be a number in [0, 1] or None, got nan"),
        ({"rate": 0.0}, "`rate` must be a number > 0, got 0.0"),
        ({"rate": math.inf}, "`rate` must be a number > 0, got inf"),
        ({"colour": "gren"}, "`colour`: unknown colour 'gren' (did you mean 'green'? known: red,"),
        ({"on": 1}, "`on` must be True or False, got 1"),
        ({"table": [1]}, "`table` must be a dict or None, got [1]"),
        ({"even": "odd"}, "`even` must be an even-length text, got 'odd'"),
        ({"share": 0.5, "count": 6}, "`share` needs `count` at most 5, got 6"),
        ({"cuont": 2}, "`cuont` is not an option of Toy (did you mean 'count'? known: count,"),
    ],
)
def test_every_refusal_is_one_option_error_naming_the_option(values, needle):
    with pytest.raises(OptionError) as info:
        Toy(**values)
    message = str(info.value)
    assert message.startswith(needle) and "\n" not in message, message
    assert isinstance(info.value, ValueError) and isinstance(info.value, TypeError)
    assert info.value.option == next(iter(values)) or info.value.option == "share"


def test_frozen_replace_checks_again_and_of_coerces():
    toy = Toy(count=4)
    with pytest.raises(dataclasses.FrozenInstanceError):
        toy.count = 5  # type: ignore[misc]
    assert toy.replace(colour="blue") == Toy(count=4, colour="blue")
    with pytest.raises(OptionError, match="`count`"):
        toy.replace(count=11)
    with pytest.raises(OptionError, match="is not an option of Toy"):
        toy.replace(colr="blue")
    assert Toy.of(None) == Toy() and Toy.of(toy) is toy and Toy.of({"count": 4}) == toy
    with pytest.raises(OptionError, match="must be a Toy, a mapping or None"):
        Toy.of(4)  # type: ignore[arg-type]


def test_a_passed_on_option_is_the_same_declaration():
    assert Passing.spec("colour").constraints == Toy.spec("colour").constraints
    assert Passing().colour == "red"
    with pytest.raises(OptionError, match="`colour`: unknown colour 'pink' \\(known: red,"):
        Passing(colour="pink")


def test_a_default_that_cannot_work_fails_where_it_is_declared():
    with pytest.raises(OptionError, match="`n` must be an integer in \\[1, 2\\], got 5"):

        class Bad(Options):
            n: int = option(Interval(int, 1, 2), default=5, doc="n")


def test_numpy_numbers_are_numbers():
    assert Toy(count=np.int64(4), share=np.float64(0.5)).count == 4
    check_argument("seed", np.uint32(7), SEED)


def test_seeds_and_arguments():
    check_argument("seed", 2**63 - 1, SEED)
    for bad in (-1, 2**63, 1.0, "3"):
        with pytest.raises(OptionError, match=r"`seed` must be an integer in \[0, 2\^63 - 1\]"):
            check_argument("seed", bad, SEED)
    check_argument("x", None, SEED, None)


@pytest.mark.parametrize(
    ("name", "text", "value"),
    [("count", "7", 7), ("count", " 7 ", 7), ("share", "0.25", 0.25), ("colour", "blue", "blue")],
)
def test_a_flag_is_parsed_by_its_declaration(name, text, value):
    assert Toy.spec(name).parse(text) == value


@pytest.mark.parametrize(
    ("name", "text", "problem"),
    [
        ("count", "x", "'x' is not an integer"),
        ("count", "11", "must be an integer in [1, 10], got 11"),
        ("share", "nan", "must be a number in [0, 1], got nan"),  # a flag never says None
        ("colour", "bleu", "unknown colour 'bleu' (did you mean 'blue'? known: red, green, blue)"),
    ],
)
def test_a_flag_refusal_is_the_options(name, text, problem):
    with pytest.raises(OptionError) as info:
        Toy.spec(name).parse(text)
    assert info.value.problem == problem


def test_a_choice_reads_a_registry_or_a_late_table():
    table = Registry("colour", ("red", "green"), name=str)
    assert OneOf(table).known() == ("red", "green")
    assert OneOf(lambda: ["late"]).accepts("late") and not OneOf(lambda: ["late"]).accepts(3)
    assert OneOf(table).unknown("gren") == (
        "unknown colour 'gren' (did you mean 'green'? known: red, green)"
    )
    assert unknown_name("colour", "x", table) == "unknown colour 'x' (known: red, green)"
    late = OneOf(lambda: table)
    assert late.lazy and not OneOf(table).lazy and late.table() is table


def test_a_late_table_is_read_only_for_a_value_not_the_default():
    read = []

    def table():
        read.append(1)
        return ("a", "b")

    class Late(Options):
        x: str = option(OneOf(table), default="a", doc="x")

    assert Late().x == "a" and read == []  # made without reading the table
    assert Late(x="b").x == "b" and read == [1]
    with pytest.raises(OptionError, match="`x`: unknown choice 'c'"):
        Late(x="c")


@given(
    low=st.integers(-100, 100),
    width=st.integers(0, 100),
    value=st.integers(-300, 300),
    open_low=st.booleans(),
    open_high=st.booleans(),
)
def test_an_integer_interval_is_its_definition(low, width, value, open_low, open_high):
    high = low + width
    iv = Interval(int, low, high, open_low=open_low, open_high=open_high)
    left = value > low if open_low else value >= low
    right = value < high if open_high else value <= high
    assert iv.accepts(value) == (left and right)
    assert not iv.accepts(float(value)) and not iv.accepts(True)


@given(value=st.floats(allow_nan=True, allow_infinity=True), low=st.floats(-1e6, 1e6))
def test_a_float_interval_accepts_finite_numbers_above_its_low(value, low):
    iv = Interval(float, low, None)
    assert iv.accepts(value) == (math.isfinite(value) and value >= low)
    assert iv.accepts(int(low) + 1) == (int(low) + 1 >= low)  # an int is a number too


@given(st.floats(allow_nan=False))
def test_parse_number_reads_every_float_python_writes(x):
    assert parse_number(repr(x)) == x
    assert parse_number(f"  {x!r} ") == x


@given(st.integers())
def test_parse_number_reads_every_integer_python_writes(n):
    assert parse_number(str(n), int) == n


@pytest.mark.parametrize(
    ("text", "kind", "message"),
    [
        ("0.7_5", float, "'0.7_5' is not a number"),  # Python's float reads 0.75
        ("1_000", int, "'1_000' is not an integer"),  # Python's int reads 1000
        ("1e-400", float, "'1e-400' is too small for a float, which would read it as 0"),
        ("٣", int, "'٣' is not an integer"),  # a digit of another script: int reads 3
        ("0x10", int, "'0x10' is not an integer"),
        ("2.5", int, "'2.5' is not an integer"),
        ("", float, "'' is not a number"),
    ],
)
def test_parse_number_refuses_what_the_files_refuse(text, kind, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        parse_number(text, kind)


def test_parse_number_keeps_zero_nan_and_infinity():
    assert parse_number("0e5") == 0.0 and parse_number("-0.000") == 0.0
    assert math.isnan(parse_number("nan")) and parse_number("-inf") == -math.inf
