"""The flags' types and the one-line parser, on their own: each type converts what it allows and
refuses the rest with the sentence its option's declaration says; the parser refuses in one line
naming its command; the library's `parameter` names become the flags that set them."""

from __future__ import annotations

import argparse
import math
import re

import pytest

from mirl._validation import Interval, OneOf, Spec
from mirl.cli.flags import (
    PARAMETER_FLAGS,
    OneLineParser,
    bounded_int,
    constrained,
    finite_float,
    float_at_least,
    float_between,
    fraction,
    in_flags,
    memory_size,
    non_negative_float,
    parse_damage,
    parse_same_frame,
    parse_topic,
    positive_float,
    seed,
    spec_type,
    step_seconds,
    step_seconds_or_auto,
)
from mirl.cli.parser import build_parser
from mirl.learning.options import LearnOptions


def refusal(parse, text: str) -> str:
    with pytest.raises(argparse.ArgumentTypeError) as info:
        parse(text)
    return str(info.value)


def test_a_constrained_type_converts_and_states_its_requirement():
    ints = constrained(Interval(int, 1, 5))
    assert ints("3") == 3 and isinstance(ints("3"), int)
    assert refusal(ints, "6") == "must be an integer in [1, 5], got 6"
    assert refusal(ints, "2.5") == "'2.5' is not an integer"
    assert bounded_int(1, 5)("5") == 5 and refusal(bounded_int(1, 5), "0").endswith("got 0")
    assert fraction("0.25") == 0.25 and refusal(fraction, "1.5").endswith("got 1.5")
    assert seed("0") == 0 and "got -1" in refusal(seed, "-1")


def test_a_flag_refuses_in_the_words_of_its_option():
    """The flag of an option and the option itself say the same sentence about a bad value."""
    spec = LearnOptions.__options__["max_iterations"]
    flag_says = refusal(spec_type(spec), "0")
    with pytest.raises(ValueError) as option_says:
        LearnOptions(max_iterations=0)
    assert flag_says in str(option_says.value)
    assert spec_type(spec).__name__ == spec.requirement()  # argparse shows it in its message


def test_a_choice_type_names_the_nearest():
    parse = spec_type(Spec("go", (OneOf(("adaptive", "value"), "go rule"),), doc=""))
    assert parse("value") == "value"
    assert "did you mean 'adaptive'" in refusal(parse, "adaptiv")


@pytest.mark.parametrize(
    "parse, good, bad, needle",
    [
        (positive_float, ["0.5", "1e3"], ["0", "-1", "inf", "nan", "x"], "positive"),
        (non_negative_float, ["0", "2"], ["-0.1", "inf"], "non-negative"),
        (finite_float, ["-5", "0", "7"], ["inf", "-inf", "nan"], "finite"),
        (float_at_least(2.0, strict=False), ["2", "3"], ["1.99"], "finite"),
    ],
)
def test_floats_at_least_a_bound(parse, good, bad, needle):
    for text in good:
        assert parse(text) == float(text)
    for text in bad:
        message = refusal(parse, text)
        assert needle in message or "not a number" in message or "got nan" in message


def test_floats_between_bounds_state_them_and_their_unit():
    parse = float_between(1.0, 2.0, " m")
    assert parse("1") == 1.0 and parse("2") == 2.0
    assert refusal(parse, "2.5") == "must be a number in [1, 2] m, got 2.5"
    assert refusal(parse, "nan") == "must be a number, got nan"
    assert parse.__name__ == "a number in [1, 2]"
    assert step_seconds("2") == 2.0
    assert step_seconds_or_auto(" Auto ") == "auto" and step_seconds_or_auto("0.5") == 0.5
    assert refusal(step_seconds_or_auto, "0").endswith("; or auto, the robots' own pace")
    assert refusal(step_seconds, "0.0001").startswith("must be a number in [0.001, 3600] s")


def test_a_negative_zero_is_read_as_zero():
    # `run --observability -0` printed "observability -0 (0/31 cells)" and `--p -0` "p=-0"
    for parse in (fraction, float_between(0.0, 1.0), non_negative_float, finite_float):
        for text in ("-0", "-0.0", " -0e3 "):
            value = parse(text)
            assert value == 0.0 and math.copysign(1.0, value) == 1.0, (parse, text)
            assert f"{value:g}" == "0"


@pytest.mark.parametrize(
    "text, size",
    [("64M", 64 * 2**20), ("4G", 4 * 2**30), ("1.5 GB", int(1.5 * 2**30)), ("100000000", 10**8)],
)
def test_memory_sizes_in_binary_units(text, size):
    assert memory_size(text) == size


@pytest.mark.parametrize(
    "text, needle", [("63M", "at least 64M"), ("4X", "not a size"), ("", "not a size")]
)
def test_memory_sizes_that_cannot_work_are_refused(text, needle):
    assert needle in refusal(memory_size, text)


def test_pairs_of_the_command_line():
    assert parse_topic(" /tb_i/amcl_pose = I ") == ("/tb_i/amcl_pose", "I")
    assert parse_topic("/tf:base=link=J") == ("/tf:base=link", "J")  # the last '=' splits
    assert parse_same_frame("/odom=/map") == ("odom", "map")
    assert parse_damage("J: left_wheel =0.7") == ("J", "left_wheel", 0.7)
    for parse, text in ((parse_topic, "I"), (parse_same_frame, "odom"), (parse_damage, "J:x")):
        with pytest.raises(ValueError, match=re.escape(f"'{text}': expected")):
            parse(text)


def test_the_parser_refuses_in_one_line_and_exits_2(capsys):
    parser = OneLineParser(prog="mirl demo")
    parser.add_argument("--seed", type=int)
    with pytest.raises(SystemExit) as info:
        parser.parse_args(["--sede", "1"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert err == "mirl demo: error: unrecognized argument --sede (did you mean --seed?)\n"
    with pytest.raises(SystemExit):
        parser.parse_args(["--seed", "x"])
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.endswith("(see mirl demo --help)\n")


def test_an_unrecognised_argument_is_refused_by_its_sub_command():
    parser = OneLineParser(prog="mirl")
    sub = parser.add_subparsers(dest="command")
    run = sub.add_parser("run", prog="mirl run")
    run.add_argument("--obs-steps")
    parsed = parser.parse_known_args(["run", "--obs-stesp", "3"])[0]
    assert parser._chosen(parsed) is run
    assert run.unrecognized(["3", "--obs-stesp"]) == (
        "unrecognized argument --obs-stesp (did you mean --obs-steps?)"
    )
    assert run.unrecognized(["extra"]) == "unrecognized argument extra"


def test_help_shows_defaults_and_a_switch_as_off():
    parser = OneLineParser(prog="mirl demo")
    parser.add_argument("--runs", type=int, default=20, help="runs")
    parser.add_argument("--learn-once", action="store_true", help="learn once")
    parser.add_argument("--p", type=float, help="fixed p (None: 0.9)")
    text = " ".join(parser.format_help().split())
    assert "runs (default: 20)" in text and "learn once (default: off)" in text
    assert "fixed p (None: 0.9)" in text and "default: None" not in text


def test_library_messages_name_the_flags():
    assert in_flags("`max_wait` must be an integer") == "--max-wait must be an integer"
    assert in_flags("`random_state` and `step_seconds`") == "--seed and --step-seconds"
    assert in_flags("`not_a_parameter` stays") == "`not_a_parameter` stays"


def test_every_flag_a_message_may_name_is_a_flag_of_the_command_line():
    flags = set()
    stack = [build_parser()]
    while stack:
        parser = stack.pop()
        for action in parser._actions:
            flags.update(action.option_strings)
            if isinstance(action, argparse._SubParsersAction):
                stack.extend(action.choices.values())
    assert sorted(set(PARAMETER_FLAGS.values()) - flags) == []
