"""Validation of command-line flags where they enter: argparse types made from the same
constraints the option types declare (:mod:`mirl._validation`), and a parser whose every
refusal is one line that names the sub-command and the flag and suggests the nearest flag or
name (``mirl run: error: unrecognized argument --sead (did you mean --seed?)``), exit 2 and no
usage dump."""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Sequence
from typing import Any, NoReturn

from mirl._registry import did_you_mean
from mirl._validation import (
    SEED,
    Constraint,
    Interval,
    OptionError,
    Spec,
    parse_number,
    unknown_name,
)
from mirl.experiments.options import RunProtocol, SweepOptions
from mirl.learning.options import LearnOptions

__all__ = [
    "OneLineParser",
    "constrained",
    "spec_type",
    "bounded_int",
    "fraction",
    "float_at_least",
    "positive_float",
    "finite_float",
    "non_negative_float",
    "float_between",
    "step_seconds",
    "step_seconds_or_auto",
    "seed",
    "memory_size",
    "MAX_STEPS",
]

# sizes that cannot work are refused at the flag, with the limit in the message:
MAX_STEPS = 1_000_000  # `simulate --steps`: the record is 2 x 3 int64 per step (48 MB at the cap)


class _HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Defaults in help; a switch's is "off" (its option's value is the flag's opposite when
    the flag turns a default of True over, as ``--learn-once`` does ``relearn``); a flag left
    out by default shows none (its help says what leaving it out means: "None: 0.9")."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if isinstance(action, argparse._StoreTrueAction | argparse._StoreFalseAction):
            return f"{action.help} (default: off)"
        if action.default is None:
            return action.help
        return super()._get_help_string(action)


_NUMBER_LIKE = re.compile(r"-(\d|\.\d|inf|nan)", re.IGNORECASE)
"""A command-line string that starts like a negative number: a value, never a flag."""
_GIVEN = "_mirl_given"  # the namespace's record of the flags given, removed after parsing


class _StoreOnce(argparse._StoreAction):
    """argparse's ``store``, refusing a flag given twice with two values: argparse keeps the
    last silently, so ``--seed 1 ... --seed 2`` would drop a setting without a word."""

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        given = namespace.__dict__.setdefault(_GIVEN, {})
        # compared as written back: nan is not equal to itself, and a value given twice is
        # one setting whatever it is
        if self.dest in given and _typed(given[self.dest][1]) != _typed(values):
            first, before = given[self.dest]
            raise argparse.ArgumentError(
                self,
                f"given twice ({first} {_typed(before)} and {option_string} {_typed(values)}); "
                "give it once",
            )
        given[self.dest] = (option_string, values)
        super().__call__(parser, namespace, values, option_string)


def _typed(values: Any) -> str:
    """A flag's value(s) as they read on a command line."""
    return " ".join(map(str, values)) if isinstance(values, list) else str(values)


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser that shows defaults in help and reports a bad flag in one line naming
    its sub-command: an unknown flag or an unknown choice with the nearest known ones.

    Parameters
    ----------
    *args : tuple
        :class:`argparse.ArgumentParser`'s positional arguments.
    **kwargs : dict
        Its keyword arguments; ``formatter_class`` defaults to one that shows each flag's
        default in its help (a switch's as "off").
    """

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("formatter_class", _HelpFormatter)
        super().__init__(*args, **kwargs)
        self.register("action", None, _StoreOnce)
        self.register("action", "store", _StoreOnce)

    def error(self, message: str) -> NoReturn:
        """Refuse the command line in one line naming this parser's command, exit code 2.

        Parameters
        ----------
        message : str
            The message argparse gives (its whitespace folded into one line); one that
            suggests no name gets a pointer to ``--help``.

        Raises
        ------
        SystemExit
            Always, with status 2.
        """
        msg = " ".join(message.split())
        if "did you mean" not in msg and "known: " not in msg:
            msg += f" (see {self.prog} --help)"
        self.exit(2, f"{self.prog}: error: {msg}\n")

    def exit(self, status: int = 0, message: str | None = None) -> NoReturn:
        """Write ``message`` to stderr and exit with ``status``.

        Parameters
        ----------
        status : int, default 0
            The exit code.
        message : str, optional
            What to write first (nothing if None).

        Raises
        ------
        SystemExit
            Always, with ``status``.
        """
        if message:
            sys.stderr.write(message)
        raise SystemExit(status)

    def _parse_optional(self, arg_string: str) -> Any:
        # argparse takes a value that starts with "-" for a flag unless it is a plain negative
        # number, so "--max-memory -1G" or "--observability -inf" were refused as "expected
        # one argument" of a flag that was given one; no mirl flag starts with a digit, a
        # point, inf or nan, so such a string is a value, which the flag's own check refuses
        # by name.
        if _NUMBER_LIKE.match(arg_string):
            return None
        return super()._parse_optional(arg_string)

    def parse_args(self, args: Sequence[str] | None = None, namespace: Any = None) -> Any:  # type: ignore[override]
        """As argparse's, but an unrecognised argument is refused by the sub-command it was
        given to, with the nearest of its flags.

        Parameters
        ----------
        args : sequence of str, optional
            The arguments (``sys.argv[1:]`` if None).
        namespace : argparse.Namespace, optional
            Where to put the values (a new one if None).

        Returns
        -------
        argparse.Namespace
            The parsed flags and arguments.
        """
        parsed, extra = self.parse_known_args(args, namespace)
        parsed.__dict__.pop(_GIVEN, None)
        if extra:
            parser = self._chosen(parsed)
            parser.error(parser.unrecognized(extra))
        return parsed

    def _chosen(self, parsed: Any) -> OneLineParser:
        """The sub-command's parser that parsed ``parsed`` (this one if none)."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                chosen = action.choices.get(getattr(parsed, action.dest, None) or "")
                if isinstance(chosen, OneLineParser):
                    return chosen._chosen(parsed)
        return self

    def unrecognized(self, extra: list[str]) -> str:
        """The refusal of the first unrecognised argument, with this parser's nearest flags.

        Parameters
        ----------
        extra : list of str
            The arguments no flag took; the first that looks like a flag is refused (else the
            first).

        Returns
        -------
        str
            ``unrecognized argument --sead (did you mean --seed?)``.
        """
        first = next((a for a in extra if a.startswith("-")), extra[0])
        flag = first.split("=", 1)[0]
        known = [s for a in self._actions for s in a.option_strings if s.startswith("--")]
        near = did_you_mean(flag, known, n=1) if flag.startswith("-") else []
        hint = f" (did you mean {near[0]}?)" if near else ""
        return f"unrecognized argument {first}{hint}"

    def _check_value(self, action: argparse.Action, value: Any) -> None:
        # an unknown choice (a method, a world, an experiment, a sub-command) with the nearest
        if action.choices is not None and value not in action.choices:
            kind = action.dest.replace("_", " ")  # "method", "world", "command", …
            raise argparse.ArgumentError(action, unknown_name(kind, value, action.choices))


def constrained(*constraints: Constraint) -> Any:
    """An argparse type: text converted and checked against ``constraints`` (one line naming
    the requirement, as the option types' errors do).

    Parameters
    ----------
    *constraints : Constraint
        What the value must satisfy (one of them), as an option's declaration states it
        (:class:`~mirl._validation.Interval`, …).

    Returns
    -------
    callable
        ``parse(text)``, the flag's value or :class:`argparse.ArgumentTypeError`.
    """
    return spec_type(Spec(None, constraints, doc=""))


def spec_type(spec: Spec) -> Any:
    """The argparse type of an option's flag: its text parsed and checked by the option's
    declaration (:meth:`mirl._validation.Spec.parse`).

    Parameters
    ----------
    spec : Spec
        The option's declaration.

    Returns
    -------
    callable
        ``parse(text)``, the flag's value or :class:`argparse.ArgumentTypeError`; its
        ``__name__`` is the requirement, which argparse shows in its message.
    """

    def parse(text: str) -> Any:
        """Parse a flag's text and check it against its declaration.

        Parameters
        ----------
        text : str
            The flag's value as typed.

        Returns
        -------
        object
            The value, converted.

        Raises
        ------
        argparse.ArgumentTypeError
            If the text is not a value the declaration allows (its sentence).
        """
        try:
            value = spec.parse(text)
        except OptionError as exc:
            raise argparse.ArgumentTypeError(exc.problem) from None
        return _unsigned_zero(value)

    parse.__name__ = spec.requirement()
    return parse


def bounded_int(low: int, high: int) -> Any:
    """An argparse type: an integer in [low, high].

    Parameters
    ----------
    low, high : int
        The bounds, both allowed.

    Returns
    -------
    callable
        ``parse(text)``, the integer or :class:`argparse.ArgumentTypeError`.
    """
    return constrained(Interval(int, low, high))


seed = constrained(SEED)
fraction = constrained(Interval(float, 0.0, 1.0))  # a degree or a probability


def _float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if v != v:
        raise argparse.ArgumentTypeError("must be a number, got nan")
    return _unsigned_zero(v)


def _unsigned_zero(value: Any) -> Any:
    """``-0`` typed on a flag is 0: a float's sign of zero would reach the reports and JSON
    (``observability -0 (0/31 cells)``, ``p=-0``), though it means nothing."""
    return value + 0.0 if isinstance(value, float) else value


def float_at_least(low: float, *, strict: bool):
    """An argparse type: a finite number > ``low`` (``strict``) or >= ``low``.

    Parameters
    ----------
    low : float
        The bound (``-inf``: any finite number).
    strict : bool
        Whether ``low`` itself is refused.

    Returns
    -------
    callable
        ``parse(text)``, the number or :class:`argparse.ArgumentTypeError`.
    """

    def parse(text: str) -> float:
        """Parse a flag's text as a finite number beyond its bound.

        Parameters
        ----------
        text : str
            The flag's value as typed.

        Returns
        -------
        float
            The number.

        Raises
        ------
        argparse.ArgumentTypeError
            If the text is not a number, is NaN or infinite, or is not beyond the bound.
        """
        v = _float(text)
        if not (v < float("inf") and (v > low if strict else v >= low)):
            what = "non-negative" if not strict else "positive" if low == 0.0 else "finite"
            raise argparse.ArgumentTypeError(f"must be a finite {what} number, got {text}")
        return v

    return parse


positive_float = float_at_least(0.0, strict=True)
finite_float = float_at_least(float("-inf"), strict=True)
non_negative_float = float_at_least(0.0, strict=False)


def float_between(low: float, high: float, unit: str = ""):
    """An argparse type: a number in [low, high] (the limits stated in the refusal).

    Parameters
    ----------
    low, high : float
        The bounds, both allowed.
    unit : str, default ""
        The unit written after the bounds in the refusal (``" s"``).

    Returns
    -------
    callable
        ``parse(text)``, the number or :class:`argparse.ArgumentTypeError`.
    """

    def parse(text: str) -> float:
        """Parse a flag's text as a number within its bounds.

        Parameters
        ----------
        text : str
            The flag's value as typed.

        Returns
        -------
        float
            The number.

        Raises
        ------
        argparse.ArgumentTypeError
            If the text is not a number or lies outside the bounds.
        """
        v = _float(text)
        if not low <= v <= high:
            raise argparse.ArgumentTypeError(
                f"must be a number in [{low:g}, {high:g}]{unit}, got {v:g}"
            )
        return v

    parse.__name__ = f"a number in [{low:g}, {high:g}]"
    return parse


# seconds per time step: from a millisecond to an hour (a step of 1e-300 s or 1e308 s spans
# more steps, or fewer poses, than any record holds)
step_seconds = float_between(0.001, 3600.0, " s")


def step_seconds_or_auto(text: str):
    """An argparse type: seconds per time step, or ``auto`` (the robots' own pace).

    Parameters
    ----------
    text : str
        The flag's value as typed.

    Returns
    -------
    float or str
        The seconds, or ``"auto"``.

    Raises
    ------
    argparse.ArgumentTypeError
        If the text is neither ``auto`` nor a number of seconds within the limits.
    """
    if text.strip().lower() == "auto":
        return "auto"
    try:
        return step_seconds(text)
    except argparse.ArgumentTypeError as exc:
        raise argparse.ArgumentTypeError(f"{exc}; or auto, the robots' own pace") from None


_SIZE_UNITS = {"": 1, "B": 1, "K": 2**10, "KB": 2**10, "M": 2**20, "MB": 2**20, "G": 2**30,
               "GB": 2**30, "T": 2**40, "TB": 2**40}  # fmt: skip


def memory_size(text: str) -> int:
    """An argparse type: a memory size, ``4G``, ``500MB``, ``1.5 GB`` (binary units; no unit:
    bytes), at least 64 MB (less than the interpreter with numpy alone).

    Parameters
    ----------
    text : str
        The flag's value as typed.

    Returns
    -------
    int
        Bytes.

    Raises
    ------
    argparse.ArgumentTypeError
        If the text is not a size or is under 64 MB.
    """
    m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+)\s*([A-Za-z]*)\s*", text)
    unit = m.group(2).upper() if m else ""
    if m is None or unit not in _SIZE_UNITS:
        raise argparse.ArgumentTypeError(f"'{text}' is not a size such as 4G or 500M")
    v = int(float(m.group(1)) * _SIZE_UNITS[unit])
    if v < 64 * 2**20:
        raise argparse.ArgumentTypeError(f"must be at least 64M, got {text}")
    return v


def parse_topic(text: str) -> tuple[str, str]:
    """``--topic TOPIC=ROBOT`` (``--topic /tb_i/amcl_pose=I``, or for a robot recorded only as
    a TF frame ``--topic /tf:base_footprint=I``)."""
    topic, sep, robot = text.rpartition("=")
    if not sep or not topic.strip() or not robot.strip():
        raise ValueError(
            f"--topic '{text}': expected TOPIC=ROBOT, e.g. /tb_i/amcl_pose=I or "
            "/tf:base_footprint=I"
        )
    return topic.strip(), robot.strip()


def parse_same_frame(text: str) -> tuple[str, str]:
    """``--same-frame FRAME=MAP_FRAME`` (``--same-frame odom=map``)."""
    frame, sep, other = text.partition("=")
    if not sep or not frame.strip() or not other.strip():
        raise ValueError(f"--same-frame '{text}': expected FRAME=FRAME, e.g. odom=map")
    return frame.strip().lstrip("/"), other.strip().lstrip("/")


def parse_damage(text: str) -> tuple[str, str, float]:
    """``--damage ROBOT:FEATURE=P``."""
    try:
        robot, rest = text.split(":", 1)
        feature, value = rest.split("=", 1)
    except ValueError:
        raise ValueError(
            f"--damage '{text}': expected ROBOT:FEATURE=P, e.g. J:left_wheel=0.7"
        ) from None
    try:
        return robot.strip(), feature.strip(), float(parse_number(value))
    except ValueError as exc:
        raise ValueError(
            f"--damage '{text}': {exc} (expected ROBOT:FEATURE=P, e.g. J:left_wheel=0.7)"
        ) from None


# The library's errors name a parameter in backquotes (`step_seconds`); the command line says
# which flag sets it.
PARAMETER_FLAGS = {
    **{
        name: spec.flag
        for options in (LearnOptions, RunProtocol, SweepOptions)
        for name, spec in options.__options__.items()
        if spec.flag is not None
    },
    "seed": "--seed",
    "random_state": "--seed",
    "observability": "--observability",
    "method": "--method",
    "topics": "--topic",
    "step_seconds": "--step-seconds",
    "start_time": "--start-time",
    "tolerance": "--tolerance",
    "drop_off_map": "--drop-off-map",
    "visible": "--visible",
    "out": "--out",
    "cell_size": "--cell-size",
    "max_memory": "--max-memory",
    "same_frames": "--same-frame",
    "heading_noise": "--heading-noise",
}


def in_flags(message: str) -> str:
    """A library error message with its `parameter` names replaced by their flags."""
    return re.sub(r"`([a-z_]+)`", lambda m: PARAMETER_FLAGS.get(m.group(1), m.group(0)), message)
