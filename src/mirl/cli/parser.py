"""The argument parser of ``mirl``: every sub-command, flag, default and help text.

The flags that set an option of :class:`~mirl.learning.options.LearnOptions`,
:class:`~mirl.experiments.options.RunProtocol` or :class:`~mirl.experiments.options.SweepOptions`
are built from its declaration (:func:`_option`): the flag, its type and bounds, its choices, its
default and its help. The tables (methods, worlds, experiments, go rules) give the choices.
"""

from __future__ import annotations

import argparse
from functools import partial
from typing import Any

from mirl._validation import Boolean, Options
from mirl.cli.checks import DEFAULT_POSE_RATE
from mirl.cli.flags import (
    MAX_STEPS,
    OneLineParser,
    bounded_int,
    finite_float,
    float_between,
    fraction,
    memory_size,
    non_negative_float,
    positive_float,
    seed,
    spec_type,
    step_seconds,
    step_seconds_or_auto,
)
from mirl.experiments.options import RunProtocol, SweepOptions
from mirl.learning.methods import LEARNING_METHODS, METHODS, ruled_options
from mirl.learning.options import DEFAULT_P, EM_INITS, LABELLINGS, LearnOptions
from mirl.world.actions import STEP_SECONDS
from mirl.worlds import WORLDS

__all__ = ["build_parser"]

_DECLARED: Any = object()  # a flag's default: the option's declared one


def _option(
    sp: argparse._ActionsContainer,
    options: type[Options],
    name: str,
    *,
    default: Any = _DECLARED,
    help: str | None = None,
) -> None:
    """Add the flag of option ``name`` of ``options``, built from its declaration: a switch
    for a True/False option (its flag turns the declared default over, so it was given when
    its value is not the default), else a value checked by the declaration, with its choices.
    ``default`` None leaves the option to the library (the flag given or not: a check that it
    applies to the method needs to know), as for every option some method does not read
    (:func:`~mirl.learning.methods.ruled_options`): a flag left out never counts as given."""
    spec = options.spec(name)
    assert spec.flag is not None, f"{options.__name__}.{name} has no flag"
    text = (spec.doc if help is None else help).replace("%", "%%")  # argparse formats help
    if any(isinstance(c, Boolean) for c in spec.constraints):
        action = "store_false" if spec.default else "store_true"
        sp.add_argument(spec.flag, dest=name, action=action, help=text)
        return
    if default is _DECLARED and name in ruled_options():
        default = None
        if spec.default is not None:  # the help says what leaving it out means
            text += f" (None: {spec.default})"
    sp.add_argument(
        spec.flag,
        dest=name,
        type=spec_type(spec),
        choices=spec.choices,
        default=spec.default if default is _DECLARED else default,
        metavar=spec.metavar,
        help=text,
    )


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
    _observability_arg(le, "degree the observations were taken at (default: the scenario's)")
    # every option of learning that has a flag is a flag of learn: a new one needs no line here
    for name, spec in LearnOptions.__options__.items():
        if spec.flag is not None:
            {"p": _p_arg, "em_init": _em_init_arg}.get(name, partial(_learn_option, name=name))(le)
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
    steps = RunProtocol.default("obs_steps")
    _option(
        ru, RunProtocol, "obs_steps", default=None,
        help=f"observe exactly N steps ({STEP_SECONDS:g} s each), as the experiments do; None: "
        f"{steps} steps, then --watch-until-seen",
    )  # fmt: skip
    limit = RunProtocol.default("max_obs_steps")
    _option(
        ru, RunProtocol, "watch_until_seen", default=None,
        help=f"without --obs-steps: after {steps} steps L keeps watching until it has seen "
        f"every patroller on K steps, for at most {limit} steps "
        f"({limit * STEP_SECONDS / 60:g} min) "
        f"(None: {RunProtocol.default('watch_until_seen')})",
    )  # fmt: skip
    ru.add_argument("--seed", type=seed, default=0, help="seed of the whole run")
    _p_arg(ru)
    _option(ru, RunProtocol, "max_wait")
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
    """The ``mirl`` command's parser, every sub-command's flags built from the tables and the
    option types (it imports neither numpy nor scipy).

    Returns
    -------
    argparse.ArgumentParser
        A :class:`~mirl.cli.flags.OneLineParser`; ``parse_args`` puts the sub-command's name
        in ``command``.
    """
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


class _ExperimentHelp(argparse.Action):
    """``mirl experiment --help``: every experiment of the table with what it measures, read
    when asked for (building the table designs the atlas's grid, with numpy), as is a name."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, **kwargs) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, **kwargs)

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        from mirl.experiments.conditions import EXPERIMENTS, experiment_names

        listed = experiment_names()
        parser.description = (
            f"{parser.description} The experiments: "
            + "; ".join(f"{n}: {EXPERIMENTS[n].description}" for n in listed)
            + "."
        )
        for action in parser._actions:
            if action.dest == "name":
                action.help = ", ".join(listed)
        parser.print_help()
        parser.exit()


def _experiment_parsers(sub) -> None:
    ex = sub.add_parser(
        "experiment",
        help="run one of the paper's experiments or calibrations (`mirl experiment --help` "
        "lists them)",
        description="Runs a grid of conditions × seeds in parallel, committing every finished "
        "run to DIR/results.sqlite; --resume continues an interrupted (or extends a) sweep.",
        add_help=False,
    )
    ex.add_argument("-h", "--help", action=_ExperimentHelp, help="show this help message and exit")
    ex.add_argument(
        "name", metavar="NAME", type=_experiment_name, help="an experiment (listed below)"
    )
    _option(ex, SweepOptions, "world", help=_world_help())
    for name in ("runs", "workers"):
        _option(ex, SweepOptions, name)
    ex.add_argument("--out", metavar="DIR", help="results directory (None: results/NAME)")
    _option(ex, SweepOptions, "resume")
    _option(ex, SweepOptions, "dask_scheduler")
    _option(ex, SweepOptions, "base_seed")
    _option(ex, SweepOptions, "progress", help="no progress bar or progress lines")
    _option(ex, SweepOptions, "progress_every")
    _em_init_arg(ex)
    _protocol_args(ex)
    rp = sub.add_parser("report", help="figures and DIR/report.md from an experiment's results")
    rp.add_argument("dir", metavar="DIR", help="an experiment's results directory (or parent)")


def _experiment_name(text: str) -> str:
    """An experiment's name (the hidden ones too; the refusal lists the others)."""
    from mirl.experiments.conditions import EXPERIMENTS, experiment_names

    if text not in EXPERIMENTS:
        raise argparse.ArgumentTypeError(str(EXPERIMENTS.unknown(text, known=experiment_names())))
    return text


def _protocol_args(sp: argparse.ArgumentParser) -> None:
    """How L decides to go and whether it keeps learning while it waits; ``--go-rule value
    --learn-once`` is the paper's protocol."""
    _option(sp, RunProtocol, "go_rule")
    growth = RunProtocol.default("relearn_growth")
    _option(
        sp, RunProtocol, "relearn",
        help=f"learn once after observing, as published (default: re-learn while waiting, "
        f"whenever the record has grown {growth:g}x)",
    )  # fmt: skip


def _learn_option(sp: argparse.ArgumentParser, *, name: str) -> None:
    _option(sp, LearnOptions, name)


def _p_arg(sp: argparse.ArgumentParser) -> None:
    spec = LearnOptions.spec("p")
    _option(sp, LearnOptions, "p", help=f"{spec.doc} (None: {DEFAULT_P:g})")


def _em_init_arg(sp: argparse.ArgumentParser) -> None:
    _option(
        sp, LearnOptions, "em_init",
        help=f"{LearnOptions.spec('em_init').doc} (None: {EM_INITS.names[0]})",
    )  # fmt: skip


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
        "for a pose CSV, NAME=ROBOT reads the file's robot NAME as ROBOT and, once given, "
        "only the robots named (the others' poses are counted in a warning)",
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
        help="time of step 0 (default: the earliest pose read, moved to the record's phase: "
        "halfway between the robots' changes of cell)",
    )
    g.add_argument(
        "--tolerance",
        type=non_negative_float,
        default=None,
        metavar="SECONDS",
        help="a step takes the nearest pose within this, at most half a step (default: half a "
        "step)",
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
        "--steps",
        type=bounded_int(1, MAX_STEPS),
        default=300,
        help=f"time steps ({STEP_SECONDS:g} s each)",
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
        help=f"poses per second (None: {DEFAULT_POSE_RATE:g})",
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
        help=f"seconds per time step of the written poses (None: {STEP_SECONDS:g})",
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
        choices=tuple(LABELLINGS),
        default="true-policy",
        help="how observed steps are labelled with actions: "
        + "; ".join(f"{r.name}: {r.description}" for r in LABELLINGS.values()),
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


def _world_help() -> str:
    return "; ".join(
        f"{w.name}: {w.description}, where --damage sets {w.damage}"
        + (f' (pip install "mirl[{w.requirement_extra}]")' if w.requirement_extra else "")
        for w in WORLDS.values()
    )


def _world_arg(sp: argparse.ArgumentParser) -> None:
    sp.add_argument(
        "--world", choices=tuple(WORLDS), default=SweepOptions.default("world"), help=_world_help()
    )


def _observability_arg(sp: argparse.ArgumentParser, help: str) -> None:
    sp.add_argument("--observability", type=fraction, default=None, metavar="D", help=help)
