"""The argument parser of ``mirl``: every sub-command, flag, default and help text."""

from __future__ import annotations

import argparse
import os

from mirl.cli.flags import (
    MAX_OBS_STEPS,
    MAX_STEPS,
    MAX_WAIT_STEPS,
    OneLineParser,
    bounded_int,
    finite_float,
    float_between,
    fraction,
    memory_size,
    non_negative_float,
    positive_float,
    seed,
    step_seconds,
    step_seconds_or_auto,
)
from mirl.learning.methods import LEARNING_METHODS, METHODS
from mirl.worlds import DEFAULT_WORLD, WORLDS

__all__ = ["build_parser"]

# Literal copies of tuples whose modules import numpy and scipy, so that building the parser
# imports none of them; tests/cli/test_startup.py checks that they match their sources.
IRL_OBJECTIVES = ("counts", "likelihood", "both", "sequence")  # learning.irl.OBJECTIVES
IRL_OPTIMIZERS = ("nelder-mead", "lbfgs")  # learning.irl.OPTIMIZERS
RUN_MAX_WAIT = 450  # experiments.records.MAX_WAIT
RUN_WATCH_UNTIL_SEEN = 40  # experiments.records.WATCH_UNTIL_SEEN
RUN_WATCH_LIMIT = 1800  # experiments.records.WATCH_LIMIT
EM_INITS = ("intended", "uniform")  # learning.dbn_em.EM_INITS


class _VersionAction(argparse.Action):
    """``--version``, with the installed version looked up only when asked for."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, **kwargs) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        from mirl._version import package_version

        print(f"mirl {package_version()}")
        parser.exit()


def _learn_parser(sub) -> None:
    le = sub.add_parser(
        "learn",
        help="learn the patrollers' rewards, policies and transitions from a CSV (mIRL*/T+Int)",
        description="Learn per robot reward weights, policy and transition-feature "
        "probabilities, and the interaction equilibrium, from L's observations.",
    )
    _scenario_args(le)
    _observation_args(le)
    le.add_argument(
        "--method",
        choices=[m for m in LEARNING_METHODS if METHODS[m].learns],
        default="mirl-t",
        help="learning method (mirl-t is the paper's mIRL*/T+Int; see README 'Methods')",
    )
    le.add_argument(
        "--p", type=fraction, default=None, help="fixed success p of mirl / known-r (None: 0.9)"
    )
    _observability_arg(le, "degree the observations were taken at (default: the scenario's)")
    le.add_argument(
        "--max-iterations",
        type=bounded_int(1, 100),
        default=5,
        metavar="N",
        help="relabelling rounds of mirl-t / known-r-t",
    )
    le.add_argument(
        "--label-tol",
        type=fraction,
        default=0.01,
        metavar="F",
        help="mirl-t's relabelling has converged when a round changes at most this share of "
        "the labelled steps (0: none)",
    )
    le.add_argument(
        "--objective",
        choices=IRL_OBJECTIVES,
        default="sequence",
        help="IRL objective (paper: counts)",
    )
    le.add_argument(
        "--optimizer",
        choices=IRL_OPTIMIZERS,
        default="lbfgs",
        help="IRL optimiser (paper: nelder-mead)",
    )
    _em_init_arg(le)
    _max_memory_arg(le)
    le.add_argument(
        "--compare",
        choices=("auto", "truth", "observed"),
        default="auto",
        help="score the learned policies against the scenario's truth (data simulated from it) "
        "or against the observed moves only (robot data); auto: truth for grid CSVs such as "
        "mirl simulate writes, observed for bags and pose CSVs",
    )
    le.add_argument("--seed", type=seed, default=0, help="seed of the learner's random choices")
    le.add_argument("--json", action="store_true", help="print the result as one JSON object")


def _run_parser(sub) -> None:
    ru = sub.add_parser(
        "run",
        help="one penetration run: observe, learn, plan, go (default: boyd2, mirl-t, 0.14)",
        description="L observes the patrollers, learns their models, predicts them and goes "
        "for its goal; prints what it saw, learned and did, and the outcome.",
    )
    _scenario_args(ru, default="boyd2")
    _world_arg(ru)
    ru.add_argument(
        "--method",
        choices=tuple(METHODS),
        default="mirl-t",
        help="how L models the patrollers (mirl-t is the paper's mIRL*/T+Int; see README)",
    )
    _observability_arg(
        ru, "share of the patrollers' cells L sees (None: the scenario's, 0.14 on boyd2)"
    )
    ru.add_argument(
        "--obs-steps",
        type=bounded_int(1, MAX_OBS_STEPS),
        default=None,
        metavar="N",
        help="observe exactly N steps (2 s each), as the experiments do; None: 300 steps, then "
        "--watch-until-seen",
    )
    ru.add_argument(
        "--watch-until-seen",
        type=bounded_int(1, RUN_WATCH_LIMIT),
        default=None,
        metavar="K",
        help=f"without --obs-steps: after 300 steps L keeps watching until it has seen every "
        f"patroller on K steps, for at most {RUN_WATCH_LIMIT} steps "
        f"({RUN_WATCH_LIMIT * 2 // 60} min) (None: {RUN_WATCH_UNTIL_SEEN})",
    )
    ru.add_argument("--seed", type=seed, default=0, help="seed of the whole run")
    ru.add_argument(
        "--p", type=fraction, default=None, help="fixed success p of mirl / known-r (None: 0.9)"
    )
    ru.add_argument(
        "--max-wait",
        type=bounded_int(0, MAX_WAIT_STEPS),
        default=RUN_MAX_WAIT,
        metavar="N",
        help="steps L may wait after observing (450: 25 min in all with 300 observed)",
    )
    _em_init_arg(ru)
    _protocol_args(ru)
    _max_memory_arg(ru)
    ru.add_argument("--json", action="store_true", help="print the run as one JSON object")
    ru.add_argument("--plot", metavar="FILE.png", help="draw the run (.png, .pdf or .svg)")
    ru.add_argument(
        "--animate",
        metavar="FILE.gif",
        help="animate the run as a GIF: the patrollers, L's view, its wait and its drive",
    )


def build_parser() -> argparse.ArgumentParser:
    p = OneLineParser(
        prog="mirl",
        description="Learn other robots' rewards, policies and faulty motion under occlusion.",
    )
    p.add_argument("--version", action=_VersionAction, help="show the version and exit")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    _show_map_parser(sub)
    _simulate_parser(sub)
    _data_parsers(sub)
    _experiment_parsers(sub)
    _run_parser(sub)
    _learn_parser(sub)
    return p


def _experiment_parsers(sub) -> None:
    ex = sub.add_parser(
        "experiment",
        help="run one of the paper's experiments (fig3, fig4a, fig4b, fig4c, table1)",
        description="Runs a grid of conditions × seeds in parallel, committing every finished "
        "run to DIR/results.sqlite; --resume continues an interrupted (or extends a) sweep.",
    )
    ex.add_argument("name", metavar="NAME", help="fig3, fig4a, fig4b, fig4c or table1")
    _world_arg(ex)
    ex.add_argument(
        "--runs",
        type=bounded_int(1, 100_000),
        default=None,
        help="runs per condition (None: the experiment's default, 200 for the paper's)",
    )
    ex.add_argument(
        "--workers", type=bounded_int(1, 1024), default=os.cpu_count() or 1, help="local processes"
    )
    ex.add_argument("--out", metavar="DIR", help="results directory (None: results/NAME)")
    ex.add_argument("--resume", action="store_true", help="skip the runs DIR already holds")
    ex.add_argument("--dask-scheduler", metavar="ADDRESS", help="run on this Dask cluster")
    ex.add_argument("--seed", type=seed, default=0, help="base seed of the run seeds")
    ex.add_argument("--quiet", action="store_true", help="no progress bar or progress lines")
    ex.add_argument(
        "--progress-every",
        type=bounded_int(1, 100_000),
        default=None,
        metavar="N",
        help="when output is not a terminal, a progress line every N runs (None: ~every 5%%)",
    )
    _em_init_arg(ex)
    _protocol_args(ex)
    rp = sub.add_parser("report", help="figures and DIR/report.md from an experiment's results")
    rp.add_argument("dir", metavar="DIR", help="an experiment's results directory (or parent)")


# mirl.planning.go.GO_RULES, spelled out so that building the parser imports no numpy (a test
# checks that the two agree)
GO_RULE_CHOICES = ("adaptive", "value")


def _protocol_args(sp: argparse.ArgumentParser) -> None:
    """How L decides to go and whether it keeps learning while it waits; ``--go-rule value
    --learn-once`` is the paper's protocol."""
    sp.add_argument(
        "--go-rule",
        choices=GO_RULE_CHOICES,
        default="adaptive",
        help="adaptive: go when the chance of going now beats the value of waiting until the "
        "deadline, and state the exact P(success); value: the published rule (the best plan "
        "value in the window, if positive)",
    )
    sp.add_argument(
        "--learn-once",
        action="store_true",
        help="learn once after observing, as published (default: re-learn while waiting, "
        "whenever the record has grown 1.5x)",
    )


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
        "a robot recorded only in the transforms is TF_TOPIC:CHILD_FRAME, e.g. "
        "/tf:base_footprint=I (composed up to the map frame, /tf_static included); "
        "for a pose CSV, renames a robot of the file",
    )
    g.add_argument(
        "--same-frame",
        action="append",
        metavar="FRAME=FRAME",
        help="two frames that coincide (repeatable), e.g. odom=map: only then are topics "
        "recorded in both mixed",
    )
    g.add_argument(
        "--step-seconds",
        type=step_seconds_or_auto,
        default=None,
        metavar="S|auto",
        help="seconds per time step, or auto: the robots' own pace, at which a typical move "
        "is one cell (None: auto; the report states the step chosen)",
    )
    g.add_argument(
        "--start-time",
        type=finite_float,
        default=None,
        metavar="SECONDS",
        help="time of step 0 (default: the earliest pose read)",
    )
    g.add_argument(
        "--tolerance",
        type=non_negative_float,
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


def _max_memory_arg(sp: argparse.ArgumentParser) -> None:
    sp.add_argument(
        "--max-memory",
        type=memory_size,
        default=None,
        metavar="SIZE",
        help="refuse at once if the estimated peak memory exceeds SIZE (4G, 500M; None: half "
        "of this machine's memory)",
    )


def _em_init_arg(sp: argparse.ArgumentParser) -> None:
    sp.add_argument(
        "--em-init",
        choices=EM_INITS,
        default=None,
        help="DBN-EM's initial transitions: uniform over the intended states of all actions, or "
        "over all states (None: intended)",
    )


def _show_map_parser(sub) -> None:
    """``mirl show-map``."""
    sm = sub.add_parser(
        "show-map",
        help="print a map or a scenario's map (and draw it with --png)",
        description="Print a map's cells and states; for a scenario (.toml) also L's start, "
        "view and goal and the patrol routes. --png draws it, with axes in metres.",
    )
    sm.add_argument(
        "map",
        metavar="NAME_OR_PATH",
        help="shipped map name, office-RxC[-sK], text map, ROS map_server YAML or scenario TOML",
    )
    _observability_arg(sm, "shade the cells visible to L at degree D (a scenario: its own)")
    sm.add_argument("--png", metavar="FILE", help="also draw the map to a PNG file")
    sm.add_argument(
        "--cell-size",
        type=positive_float,
        default=None,
        metavar="METRES",
        help="cell size in metres for a ROS map_server map (None: 0.5, or the resolution if "
        "coarser)",
    )


def _simulate_parser(sub) -> None:
    """``mirl simulate``."""
    si = sub.add_parser("simulate", help="simulate the patrollers and record what L sees")
    _scenario_args(si)
    _world_arg(si)
    si.add_argument(
        "--steps", type=bounded_int(1, MAX_STEPS), default=300, help="time steps (2 s each)"
    )
    si.add_argument("--seed", type=seed, default=0, help="seed of the simulation")
    _observability_arg(si, "share of the patrollers' cells L sees (None: the scenario's)")
    si.add_argument(
        "--heading-noise",
        type=fraction,
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
    si.add_argument(
        "--poses",
        metavar="OUT",
        help="also write L's observations as continuous poses: a pose CSV (.csv), or an MCAP "
        "file (.mcap) / ROS 2 bag directory with a PoseStamped topic /ROBOT/pose per robot",
    )
    si.add_argument(
        "--pose-rate",
        type=float_between(0.001, 1000.0, " Hz"),
        default=None,
        metavar="HZ",
        help="poses per second (None: 10)",
    )
    si.add_argument(
        "--pose-noise",
        type=non_negative_float,
        nargs=2,
        metavar=("SIGMA_M", "SIGMA_DEG"),
        help="Gaussian noise on the poses: metres per axis and degrees of yaw",
    )
    si.add_argument(
        "--step-seconds",
        type=step_seconds,
        default=None,
        metavar="S",
        help="seconds per time step of the written poses (None: 2)",
    )


def _data_parsers(sub) -> None:
    """``mirl learn-transitions`` and ``mirl convert``."""
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
    cv = sub.add_parser(
        "convert",
        help="pose data (bag, MCAP, pose CSV) -> grid observations CSV, with per-robot counts",
        description="Discretise robot poses onto the scenario's map and steps and write them as "
        "t,robot,row,col,heading; prints per robot how many poses were read, binned, snapped "
        "and dropped, and how many steps are observed.",
    )
    cv.add_argument("input", metavar="IN", help="a .bag, ROS 2 bag directory, .mcap or CSV")
    cv.add_argument("output", metavar="OUT.csv", help="grid observations CSV to write")
    _scenario_args(cv)
    _observation_args(cv, with_file=False)


def _world_arg(sp: argparse.ArgumentParser) -> None:
    sp.add_argument(
        "--world",
        choices=tuple(WORLDS),
        default=DEFAULT_WORLD,
        help="; ".join(
            f"{w.name}: {w.description}, where --damage sets {w.damage}"
            + (f' (pip install "mirl[{w.requirement_extra}]")' if w.requirement_extra else "")
            for w in WORLDS.values()
        ),
    )


def _observability_arg(sp: argparse.ArgumentParser, help: str) -> None:
    sp.add_argument("--observability", type=fraction, default=None, metavar="D", help=help)
