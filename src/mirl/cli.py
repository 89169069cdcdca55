"""The ``mirl`` command line. Every user error ends in one line on stderr and exit code 2."""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable, Sequence

from mirl import __version__

__all__ = ["main"]

COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {}


def command(name: str):
    def register(fn):
        COMMANDS[name] = fn
        return fn

    return register


class UsageError(Exception):
    """A problem with the user's input, reported in one line."""


def _load_scenario(args: argparse.Namespace):
    from mirl.scenario import load_scenario, parse_damage

    scenario = load_scenario(args.scenario)
    for text in getattr(args, "damage", None) or []:
        robot, feature, p = parse_damage(text)
        scenario = scenario.with_damage(robot, feature, p)
    return scenario


@command("show-map")
def _show_map(args: argparse.Namespace) -> int:
    from mirl.maps import load_map
    from mirl.office_maps import office_map_from_name
    from mirl.render import map_to_text, save_map_png

    gridmap = office_map_from_name(args.map) or load_map(args.map, cell_size=args.cell_size)
    mask = gridmap.visible_mask(args.observability) if args.observability is not None else None
    print(map_to_text(gridmap, mask))
    n = gridmap.n_patroller_cells
    line = f"{gridmap.name}: {gridmap.shape[0]}x{gridmap.shape[1]}, {n} patroller cells"
    if mask is not None:
        line += f", {int(mask.sum())} visible at observability {args.observability:g}"
    print(line)
    if args.png:
        save_map_png(gridmap, args.png, observability=args.observability)
        print(f"wrote {args.png}")
    return 0


@command("simulate")
def _simulate(args: argparse.Namespace) -> int:
    from mirl.simulator import simulate

    scenario = _load_scenario(args)
    start = time.perf_counter()
    result = simulate(
        scenario,
        args.steps,
        seed=args.seed,
        observability=args.observability,
        heading_noise=args.heading_noise,
        random_starts=args.random_starts,
    )
    elapsed = time.perf_counter() - start
    share = result.observed_share()
    degree = scenario.observability if args.observability is None else args.observability
    print(
        f"scenario {scenario.name}: {args.steps} steps, seed {args.seed}, "
        f"observability {degree:g} ({int(scenario.domain.visible_states(degree).sum() // 4)}"
        f"/{scenario.map.n_patroller_cells} cells)"
    )
    for name, s in zip(scenario.robot_names, share, strict=True):
        print(f"  {name}: observed {s:.1%} of steps")
    print(f"  interactions: {result.interactions} ({result.interactions_seen} seen by L)")
    print(f"  simulated in {elapsed:.3f} s")
    if args.observations:
        result.observations.to_csv(args.observations)
        print(f"wrote {args.observations} ({len(result.observations)} rows)")
    if args.truth:
        result.truth.to_csv(args.truth)
        print(f"wrote {args.truth} ({len(result.truth)} rows)")
    if args.poses:
        _write_poses(args, scenario, result.observations)
    return 0


def _write_poses(args: argparse.Namespace, scenario, observations) -> None:
    from pathlib import Path

    from mirl.bags import is_bag, write_mcap
    from mirl.discretise import poses_from_trajectories
    from mirl.poses import write_pose_csv

    sigma_m, sigma_deg = args.pose_noise or (0.0, 0.0)
    tracks = poses_from_trajectories(
        observations,
        scenario,
        step_seconds=args.step_seconds,
        rate_hz=args.pose_rate,
        sigma_xy=sigma_m,
        sigma_yaw_degrees=sigma_deg,
        seed=args.seed,
    )
    out = Path(args.poses)
    if out.suffix == ".csv":
        write_pose_csv(tracks, out)
        what = "pose CSV"
    elif out.suffix == ".mcap" or not out.suffix or is_bag(out):
        write_mcap(tracks, out)
        what = "MCAP, topics /ROBOT/pose"
    else:
        raise UsageError(f"--poses {out}: expected a .csv or .mcap file or a bag directory")
    print(
        f"wrote {out} ({len(tracks)} poses, {what}, {args.pose_rate:g} Hz, steps of "
        f"{args.step_seconds:g} s from t = 0; noise {sigma_m:g} m / {sigma_deg:g} deg)"
    )


def _read_observations(args: argparse.Namespace, scenario, observability=None):
    from mirl.observation_sources import load_observations, parse_topic

    return load_observations(
        args.observations,
        scenario,
        topics=[parse_topic(t) for t in args.topic or []],
        step_seconds=args.step_seconds,
        start_time=args.start_time,
        tolerance=args.tolerance,
        drop_off_map=args.drop_off_map,
        visible=args.visible,
        observability=observability,
    )


@command("convert")
def _convert(args: argparse.Namespace) -> int:
    scenario = _load_scenario(args)
    args.observations = args.input
    loaded = _read_observations(args, scenario)
    loaded.trajectories.to_csv(args.output)
    if loaded.discretised is not None:
        print(f"{args.input}: " + loaded.discretised.summary())
    else:
        print(f"{args.input}: grid observations, {loaded.trajectories.horizon} steps")
    print(f"wrote {args.output} ({len(loaded.trajectories)} rows)")
    return 0


@command("learn-transitions")
def _learn_transitions(args: argparse.Namespace) -> int:
    from mirl.transitions import (
        TransitionFeatureLearner,
        observed_steps,
        perception_labels,
        policy_labels,
    )

    scenario = _load_scenario(args)
    domain = scenario.domain
    obs = _read_observations(args, scenario).trajectories
    series = [obs.state_series(domain, i) for i in range(len(scenario.robots))]
    if args.labels == "true-policy":
        # Known R/T setting: the scenario's true policies and played equilibrium label the steps
        policies = [scenario.true_policy(i) for i in range(len(scenario.robots))]
        labels = policy_labels(domain, series, policies, scenario.played_equilibrium)
    learned = {}
    for i, name in enumerate(scenario.robot_names):
        t, s, s_next = observed_steps(series[i])
        a = labels[i][t] if args.labels == "true-policy" else perception_labels(domain, s, s_next)
        learned[name] = TransitionFeatureLearner(domain, scenario.error_model).fit(s, a, s_next)
    if args.json:
        print_json({n: m.feature_probabilities_ for n, m in learned.items()})
        return 0
    features = domain.feature_map.features
    print(f"learned transition-feature probabilities ({args.labels} labels, {args.observations})")
    print(f"{'robot':<6}" + "".join(f"{f:>13}" for f in features) + f"{'steps':>8}")
    for name, m in learned.items():
        probs = m.feature_probabilities_
        lowest = min(features, key=probs.__getitem__)
        cells = "".join(f"{probs[f]:>12.3f}{'*' if f == lowest else ' '}" for f in features)
        print(f"{name:<6}{cells}{int(m.counts_.trials.sum()):>8}")
        if not m.result_.success:
            print(f"  note: {m.result_.message}")
    print("* lowest feature of the robot; uninformed features get 0.5 (maximum entropy)")
    return 0


@command("experiment")
def _experiment(args: argparse.Namespace) -> int:
    from mirl.experiments import get_experiment
    from mirl.sweep import run_experiment

    exp = get_experiment(args.name)  # unknown name: one-line error, exit 2
    out = args.out or f"results/{exp.name}"
    summary = run_experiment(
        exp,
        out,
        runs=args.runs,
        workers=args.workers,
        resume=args.resume,
        dask_scheduler=args.dask_scheduler,
        base_seed=args.seed,
        progress=not args.quiet,
    )
    print(f"wrote {out}/results.sqlite and {out}/results.csv; `mirl report {out}` draws it")
    return 1 if summary.outcomes.get("error") else 0


@command("report")
def _report(args: argparse.Namespace) -> int:
    from mirl.figures import write_report

    print(f"wrote {write_report(args.dir)}")
    return 0


@command("run")
def _run(args: argparse.Namespace) -> int:
    from mirl.runs import format_report, run_episode

    scenario = _load_scenario(args)
    result = run_episode(
        scenario,
        args.method,
        observability=args.observability,
        obs_steps=args.obs_steps,
        seed=args.seed,
        p=args.p,
        max_wait=args.max_wait,
    )
    if args.plot:
        from mirl.run_plot import save_run_png

        save_run_png(scenario, result, args.plot)
    if args.json:
        print_json(result.to_dict())
    else:
        print(format_report(scenario, result))
        if args.plot:
            print(f"wrote {args.plot}")
    return 0


@command("learn")
def _learn(args: argparse.Namespace) -> int:
    from mirl.learning import learn

    scenario = _load_scenario(args)
    degree = scenario.observability if args.observability is None else args.observability
    loaded = _read_observations(args, scenario, observability=degree)
    obs = loaded.trajectories
    result = learn(
        obs,
        scenario,
        args.method,
        p=args.p,
        visible=loaded.visible_states(scenario),
        observability=degree,
        max_iterations=args.max_iterations,
        objective=args.objective,
        optimizer=args.optimizer,
        random_state=args.seed,
    )
    names = scenario.domain.reward_feature_names
    robots = {
        r.name: {
            "weights": dict(zip(names, map(float, r.weights), strict=True)),
            "feature_probabilities": {k: float(v) for k, v in r.feature_probabilities.items()},
            "behavior_accuracy": r.behavior_accuracy,
        }
        for r in result.robots
    }
    candidates = scenario.game.equilibria()
    eq_weights = result.equilibrium_weights or (None,) * len(candidates)
    out = {
        "method": result.method,
        "scenario": scenario.name,
        "observations": str(args.observations),
        "steps": obs.horizon,
        "observability": degree,
        "robots": robots,
        "equilibrium": {
            "label": result.equilibrium.label(),
            "row": list(map(float, result.equilibrium.row)),
            "col": list(map(float, result.equilibrium.col)),
            "candidates": [
                {"label": e.label(), "weight": w}
                for e, w in zip(candidates, eq_weights, strict=True)
            ],
        },
        "iterations": result.iterations,
        "label_changes": list(result.label_changes),
        "message": result.message,
        "timings": {k: round(v, 4) for k, v in result.timings.items()},
    }
    if args.json:
        print_json(out)
        return 0
    print(
        f"{result.method} on {scenario.name}: {args.observations} ({obs.horizon} steps, "
        f"observability {degree:g})"
    )
    if loaded.discretised is not None:
        print("poses discretised: " + loaded.discretised.summary())
    for name, r in robots.items():
        print(f"robot {name}")
        print("  weights       " + "  ".join(f"{k}={v:.3f}" for k, v in r["weights"].items()))
        probs = r["feature_probabilities"]
        line = "  ".join(f"{k}={v:.3f}" for k, v in probs.items()) if probs else result.message
        print(f"  features      {line}")
        if r["behavior_accuracy"] is not None:
            print(f"  behaviour accuracy {r['behavior_accuracy']:.3f} (vs the scenario's truth)")
    weights = ", ".join(
        f"{c['label']} {c['weight']:.2f}"
        for c in out["equilibrium"]["candidates"]
        if c["weight"] is not None
    )
    print(
        f"equilibrium   {out['equilibrium']['label']}"
        + (f" (weights: {weights})" if weights else "")
    )
    changes = ", ".join(map(str, result.label_changes))
    print(
        f"iterations    {result.iterations}"
        + (f" (labels changed: {changes}; {result.message})" if changes else "")
    )
    print("timings       " + ", ".join(f"{k} {v:.2f} s" for k, v in result.timings.items()))
    return 0


def _learn_parser(sub) -> None:
    from mirl.irl import OBJECTIVES, OPTIMIZERS
    from mirl.learning import METHODS

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
    from mirl.runs import MAX_WAIT, METHODS

    ru = sub.add_parser(
        "run",
        help="one penetration run: observe, learn, plan, go (default: boyd2, mirl-t, 0.14)",
        description="L observes the patrollers, learns their models, predicts them and goes "
        "for its goal; prints what it saw, learned and did, and the outcome.",
    )
    _scenario_args(ru, default="boyd2")
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
    cv.add_argument("output", metavar="OUT.csv")
    _scenario_args(cv)
    _observation_args(cv, with_file=False)
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
    ex.add_argument("--runs", type=_positive_int, default=None, help="runs per condition")
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


def _positive_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (v > 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return v


def _non_negative_float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{text}' is not a number") from None
    if not (v >= 0 and v < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a non-negative number, got {text}")
    return v


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


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    try:
        return COMMANDS[args.command](args)
    except (ValueError, OSError, UsageError) as exc:
        # domain errors (MapError, ScenarioError, TrajectoryError, ...) already name the file
        msg = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
        print(f"mirl: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("mirl: interrupted", file=sys.stderr)
        return 130


def print_json(obj) -> None:
    print(json.dumps(obj, indent=2, sort_keys=False))


if __name__ == "__main__":
    sys.exit(main())
