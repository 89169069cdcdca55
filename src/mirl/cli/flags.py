"""Validation of command-line flags where they enter: argparse types with stated limits, and a
parser whose every refusal is one line naming the flag (``mirl run: error: argument --seed:
must be an integer >= 0, got -1``), exit 2 and no usage dump."""

from __future__ import annotations

import argparse
import re
import sys
from typing import NoReturn

__all__ = [
    "OneLineParser",
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
    "MAX_OBS_STEPS",
    "MAX_WAIT_STEPS",
]

# sizes that cannot work are refused at the flag, with the limit in the message:
MAX_STEPS = 1_000_000  # `simulate --steps`: the record is 2 x 3 int64 per step (48 MB at the cap)
# `run --obs-steps`: L's filter and learning are O(steps); 10 000 steps = 5.5 h of robot time
MAX_OBS_STEPS = 10_000
MAX_WAIT_STEPS = 10_000  # `run --max-wait`: L re-plans every 10 steps while waiting
MAX_SEED = 2**63 - 1


class OneLineParser(argparse.ArgumentParser):
    """An ArgumentParser that shows defaults in help and reports a bad flag in one line."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("formatter_class", argparse.ArgumentDefaultsHelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> NoReturn:
        msg = " ".join(message.split())
        self.exit(2, f"{self.prog}: error: {msg} (see {self.prog} --help)\n")

    def exit(self, status: int = 0, message: str | None = None) -> NoReturn:
        if message:
            sys.stderr.write(message)
        raise SystemExit(status)


def _int(text: str) -> int:
    try:
        return int(text.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not an integer") from None


def _bounded(convert, low, high, what: str, unit: str = "", show=str):
    """An argparse type: ``convert(text)`` within [low, high], the limits in the refusal."""

    def parse(text: str):
        v = convert(text)
        if not low <= v <= high:
            raise argparse.ArgumentTypeError(
                f"must be {what} in [{show(low)}, {show(high)}]{unit}, got {show(v)}"
            )
        return v

    parse.__name__ = f"{what} in [{show(low)}, {show(high)}]"
    return parse


def bounded_int(low: int, high: int):
    """An argparse type: an integer in [low, high]."""
    return _bounded(_int, low, high, "an integer")


def seed(text: str) -> int:
    v = _int(text)
    if not 0 <= v <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, 2^63 - 1], got {v}")
    return v


def _float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if v != v:
        raise argparse.ArgumentTypeError("must be a number, got nan")
    return v


def fraction(text: str) -> float:
    """An argparse type: a number in [0, 1] (a degree or a probability)."""
    v = _float(text)
    if not 0.0 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in [0, 1], got {text}")
    return v


def float_at_least(low: float, *, strict: bool):
    """An argparse type: a finite number > ``low`` (``strict``) or >= ``low``."""

    def parse(text: str) -> float:
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
    """An argparse type: a number in [low, high] (the limits stated in the refusal)."""
    return _bounded(_float, low, high, "a number", unit, show="{:g}".format)


# seconds per time step: from a millisecond to an hour (a step of 1e-300 s or 1e308 s spans
# more steps, or fewer poses, than any record holds)
step_seconds = float_between(0.001, 3600.0, " s")


def step_seconds_or_auto(text: str):
    """An argparse type: seconds per time step, or ``auto`` (the robots' own pace)."""
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
    bytes), at least 64 MB (less than the interpreter with numpy alone)."""
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
        return robot.strip(), feature.strip(), float(value)
    except ValueError:
        raise ValueError(
            f"--damage '{text}': expected ROBOT:FEATURE=P, e.g. J:left_wheel=0.7"
        ) from None


# The library's errors name a parameter in backquotes (`step_seconds`); the command line says
# which flag sets it.
PARAMETER_FLAGS = {
    "topics": "--topic",
    "step_seconds": "--step-seconds",
    "start_time": "--start-time",
    "tolerance": "--tolerance",
    "drop_off_map": "--drop-off-map",
    "visible": "--visible",
    "em_init": "--em-init",
    "go_rule": "--go-rule",
    "relearn": "--learn-once",
    "resume": "--resume",
    "out": "--out",
    "base_seed": "--seed",
    "cell_size": "--cell-size",
    "max_memory": "--max-memory",
    "same_frames": "--same-frame",
    "heading_noise": "--heading-noise",
}


def in_flags(message: str) -> str:
    """A library error message with its `parameter` names replaced by their flags."""
    return re.sub(r"`([a-z_]+)`", lambda m: PARAMETER_FLAGS.get(m.group(1), m.group(0)), message)
