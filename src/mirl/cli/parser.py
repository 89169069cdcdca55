"""The argument parser of ``mirl``: every sub-command, flag, default and help text."""

from __future__ import annotations

import argparse
import os

from mirl import __version__

__all__ = ["build_parser"]


def _learn_parser(sub) -> None:
    from mirl.learning.irl import OBJECTIVES, OPTIMIZERS
    from mirl.learning.learn import METHODS

    le = sub.add_parser(
        "learn",
        help="learn the patrollers' rewards, policies and transitions from a CSV (mIRL*/T+Int)",
        description="Learn per robot reward weights, policy and transition-feature "
        "probabilities, and the interaction equilibrium, from L's observations.",
    )
    _scenario_args(le)
    _observation_args(le)
    le.add_argument("--method", choices=[m for m in METHODS if m != "oracle"], default="mirl-t")
    le.add_argument("--p", type=_degree, default=0.9, help="fixed success p of mirl / known-r")
    le.add_argument(
        "--observability",
        type=_degree,
        default=None,
        metavar="D",
        help="degree the observations were taken at (default: the scenario's)",
    )
    le.add_argument("--max-iterations", type=_positive_int, default=5, metavar="N")
    le.add_argument("--objective", choices=OBJECTIVES, default="sequence")
    le.add_argument("--optimizer", choices=OPTIMIZERS, default="lbfgs")
    le.add_argument("--seed", type=int, default=0)
    le.add_argument("--json", action="store_true", help="print the result as one JSON object")


def _run_parser(sub) -> None:
    from mirl.experiments.records import MAX_WAIT, METHODS

    ru = sub.add_parser(
        "run",
        help="one penetration run: observe, learn, plan, go (default: boyd2, mirl-t, 0.14)",
        description="L observes the patrollers, learns their models, predicts them and goes "
        "for its goal; prints what it saw, learned and did, and the outcome.",
    )
    _scenario_args(ru, default="boyd2")
    _world_arg(ru)
    ru.add_argument("--method", choices=METHODS, default="mirl-t")
    ru.add_argument("--observability", type=_degree, default=None, metavar="D")
    ru.add_argument("--obs-steps", type=_positive_int, default=300, metavar="N")
    ru.add_argument("--seed", type=int, default=0)
    ru.add_argument("--p", type=float, default=0.9, help="fixed success p of mirl / known-r")
    ru.add_argument(
        "--max-wait",
        type=int,
        default=MAX_WAIT,
        metavar="N",
        help=f"steps L may wait after observing (default {MAX_WAIT}: 25 min in all with 300 "
        "observed)",
    )
    ru.add_argument("--json", action="store_true", help="print the run as one JSON object")
    ru.add_argument("--plot", metavar="FILE.png", help="draw the run")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="mirl",
        description="Learn other robots' rewards, policies and faulty motion under occlusion.",
    )
    p.add_argument("--version", action="version", version=f"mirl {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    sm = sub.add_parser("show-map", help="print a map (and draw it with --png)")
    sm.add_argument("map", metavar="NAME_OR_PATH")
    sm.add_argument(
        "--observability",
        type=float,
        default=None,
        metavar="D",
        help="shade the cells visible to L at degree D",
    )
    sm.add_argument("--png", metavar="FILE", help="also draw the map to a PNG file")
    sm.add_argument(
        "--cell-size", type=float, default=None, help="cell size in metres for ROS map_server maps"
    )

    si = sub.add_parser("simulate", help="simulate the patrollers and record what L sees")
    _scenario_args(si)
    _world_arg(si)
    si.add_argument("--steps", type=_positive_int, default=300)
    si.add_argument("--seed", type=int, default=0)
    si.add_argument("--observability", type=_degree, default=None, metavar="D")
    si.add_argument(
        "--heading-noise",
        type=_degree,
        default=0.0,
        metavar="EPS",
        help="probability that an observed heading is misread",
    )
    si.add_argument(
        "--random-starts",
        action="store_true",
        help="start each patroller at a random state of its patrol cycle",
    )
    si.add_argument("--observations", metavar="FILE.csv", help="write L's observations")
    si.add_argument("--truth", metavar="FILE.csv", help="write the true trajectories")
    _pose_output_args(si)
    lt = sub.add_parser(
        "learn-transitions", help="learn transition-feature probabilities (mIRL*/T) from a CSV"
    )
    _scenario_args(lt)
    _observation_args(lt)
    lt.add_argument(
        "--labels",
        choices=("true-policy", "perception"),
        default="true-policy",
        help="label observed steps with the true policy (Known R/T) or by perception",
    )
    lt.add_argument("--json", action="store_true", help="print the probabilities as JSON")
    _convert_parser(sub)
    _experiment_parsers(sub)
    _run_parser(sub)
    _learn_parser(sub)
    return p


def _pose_output_args(si: argparse.ArgumentParser) -> None:
    si.add_argument(
        "--poses",
        metavar="OUT",
        help="also write L's observations as continuous poses: a pose CSV (.csv), or an MCAP "
        "file (.mcap) / ROS 2 bag directory with a PoseStamped topic /ROBOT/pose per robot",
    )
    si.add_argument("--pose-rate", type=_positive_float, default=10.0, metavar="HZ")
    si.add_argument(
        "--pose-noise",
        type=_non_negative_float,
        nargs=2,
        metavar=("SIGMA_M", "SIGMA_DEG"),
        help="Gaussian noise on the poses: metres per axis and degrees of yaw",
    )
    si.add_argument(
        "--step-seconds",
        type=_positive_float,
        default=2.0,
        metavar="S",
        help="seconds per time step of the written poses (default 2)",
    )


def _convert_parser(sub) -> None:
    cv = sub.add_parser(
        "convert",
        help="pose data (bag, MCAP, pose CSV) -> grid observations CSV, with per-robot counts",
        description="Discretise robot poses onto the scenario's map and steps and write them as "
        "t,robot,row,col,heading; prints per robot how many poses were read, binned, snapped "
        "and dropped, and how many steps are observed.",
    )
    cv.add_argument("input", metavar="IN", help="a .bag, ROS 2 bag directory, .mcap or CSV")
    cv.add_argument("output", metavar="OUT.csv")
    _scenario_args(cv)
    _observation_args(cv, with_file=False)


def _experiment_parsers(sub) -> None:
    ex = sub.add_parser(
        "experiment",
        help="run one of the paper's experiments (fig3, fig4a, fig4b, fig4c, table1)",
        description="Runs a grid of conditions × seeds in parallel, committing every finished "
        "run to DIR/results.sqlite; --resume continues an interrupted (or extends a) sweep.",
    )
    ex.add_argument("name", metavar="NAME", help="fig3, fig4a, fig4b, fig4c or table1")
    ex.add_argument("--runs", type=_positive_int, default=None, help="runs per condition")
    _world_arg(ex)
    ex.add_argument(
        "--workers", type=_positive_int, default=os.cpu_count() or 1, help="local processes"
    )
    ex.add_argument("--out", metavar="DIR", help="results directory (default results/NAME)")
    ex.add_argument("--resume", action="store_true", help="skip the runs DIR already holds")
    ex.add_argument("--dask-scheduler", metavar="ADDRESS", help="run on this Dask cluster")
    ex.add_argument("--seed", type=int, default=0, help="base seed of the run seeds")
    ex.add_argument("--quiet", action="store_true", help="no progress bar or progress lines")
    rp = sub.add_parser("report", help="figures and DIR/report.md from an experiment's results")
    rp.add_argument("dir", metavar="DIR", help="an experiment's results directory (or parent)")


def _scenario_args(sp: argparse.ArgumentParser, default: str | None = None) -> None:
    sp.add_argument(
        "--scenario",
        default=default,
        required=default is None,
        metavar="NAME_OR_FILE",
        help="shipped scenario name or TOML file",
    )
    sp.add_argument(
        "--damage",
        action="append",
        metavar="ROBOT:FEATURE=P",
        help="override a true feature probability, e.g. J:left_wheel=0.7",
    )


def _observation_args(sp: argparse.ArgumentParser, with_file: bool = True) -> None:
    if with_file:
        sp.add_argument(
            "--observations",
            required=True,
            metavar="FILE",
            help="grid CSV (t,robot,row,col,heading), pose CSV (t,robot,x,y,yaw), ROS 1 .bag, "
            "ROS 2 bag directory or .mcap",
        )
    g = sp.add_argument_group("pose data (bags, MCAP, pose CSV)")
    g.add_argument(
        "--topic",
        action="append",
        metavar="TOPIC=ROBOT",
        help="a pose topic and the scenario robot it is (repeatable), e.g. /tb_i/amcl_pose=I; "
        "for a pose CSV, renames a robot of the file",
    )
    g.add_argument(
        "--step-seconds", type=_positive_float, default=None, metavar="S", help="default 2"
    )
    g.add_argument(
        "--start-time",
        type=float,
        default=None,
        metavar="SECONDS",
        help="time of step 0 (default: the earliest pose read)",
    )
    g.add_argument(
        "--tolerance",
        type=_non_negative_float,
        default=None,
        metavar="SECONDS",
        help="a step takes the nearest pose within this (default: half a step)",
    )
    g.add_argument(
        "--drop-off-map",
        action="store_true",
        help="drop (and count) poses more than half a cell from the hallway instead of failing",
    )
    g.add_argument(
        "--visible",
        choices=("observed",),
        default=None,
        help="cells L could see: default the observability degree's; 'observed': every cell "
        "a robot was observed on",
    )


def _float_at_least(low: float, *, strict: bool):
    """An argparse type: a finite number > ``low`` (``strict``) or >= ``low``."""

    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
        if not (v < float("inf") and (v > low if strict else v >= low)):
            what = "positive" if strict else "non-negative"
            raise argparse.ArgumentTypeError(f"must be a {what} number, got {text}")
        return v

    return parse


_positive_float = _float_at_least(0.0, strict=True)
_non_negative_float = _float_at_least(0.0, strict=False)


def _world_arg(sp: argparse.ArgumentParser) -> None:
    sp.add_argument(
        "--world",
        choices=("grid", "physics"),
        default="grid",
        help="grid simulator (default) or the physical world: differential-drive robots in "
        'MuJoCo seen through cameras (pip install "mirl[physics]"); there --damage '
        "ROBOT:left_wheel=S sets a wheel motor's strength S",
    )


def _positive_int(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not an integer") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {v}")
    return v


def _degree(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not 0.0 <= v <= 1.0:
        raise argparse.ArgumentTypeError(f"must be in [0, 1], got {v}")
    return v
