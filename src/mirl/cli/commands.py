"""The sub-commands of ``mirl``: each parses nothing itself, imports what it needs when it runs
(so building the parser stays cheap) and prints its result; errors propagate to :func:`main`."""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

from mirl._validation import Options
from mirl.cli.checks import (
    FIGURE_SUFFIXES,
    MIN_TRIALS,
    UsageError,
    check_csv_output,
    check_damage,
    check_damage_once,
    check_distinct,
    check_experiment_flags,
    check_observations,
    check_output,
    check_pose_flags,
    check_poses_output,
    check_visible,
    feature_trials,
    unique_lowest,
    warn,
)
from mirl.cli.flags import parse_damage, parse_same_frame, parse_topic
from mirl.experiments.options import RunProtocol, SweepOptions
from mirl.learning.options import LearnOptions
from mirl.world.actions import HEADING_NAMES
from mirl.worlds import DEFAULT_WORLD, WorldSpec, get_world

__all__ = ["COMMANDS", "UsageError", "print_json"]

COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {}
OptionsT = TypeVar("OptionsT", bound=Options)


def command(name: str):
    def register(fn):
        COMMANDS[name] = fn
        return fn

    return register


def _load_scenario(args: argparse.Namespace):
    from mirl.world.scenario import load_scenario

    scenario = load_scenario(args.scenario)
    world = _world(getattr(args, "world", DEFAULT_WORLD))
    texts = getattr(args, "damage", None) or []
    check_damage_once([parse_damage(text) for text in texts])
    for text in texts:
        robot, feature, p = parse_damage(text)
        try:  # what the value means is the world's: a success probability, a motor strength
            scenario = world.load().apply_damage(scenario, robot, feature, p)
        except ValueError as exc:  # name the flag, as parse_damage's own errors do
            raise UsageError(f"--damage '{text}': {exc}") from None
    return scenario


def _world(name: str) -> WorldSpec:
    """The row of world ``name``, refused in one line naming the extra to install when its
    optional dependencies are missing (exit 2)."""
    world = get_world(name)
    try:
        world.check()
    except ImportError as exc:
        raise UsageError(str(exc)) from None
    return world


# a text map is printed along with --png only if it fits a terminal
TEXT_MAP_LIMIT = (60, 100)  # rows, columns


@command("show-map")
def _show_map(args: argparse.Namespace) -> int:
    from mirl.viz.maps import map_to_text, save_map_png
    from mirl.world.catalog import is_ros_map, load_map

    if args.png:
        check_output(args.png, "--png", FIGURE_SUFFIXES)
    scenario = None
    if Path(args.map).suffix.lower() == ".toml" or _names_a_scenario_only(args.map):
        from mirl.world.scenario import load_scenario

        if args.cell_size is not None:
            raise UsageError(
                f"--cell-size applies to a map, not to the scenario {args.map} "
                "(a scenario sets its ROS map's cell size in [frame] cell_size)"
            )
        scenario = load_scenario(args.map)
        gridmap = scenario.map
    else:
        if args.cell_size is not None and not is_ros_map(args.map):
            raise UsageError(
                f"--cell-size applies to ROS map_server maps (.yaml), not to {args.map} "
                "(a text map's cells are its characters)"
            )
        gridmap = load_map(args.map, cell_size=args.cell_size)
    degree = args.observability
    if degree is None and scenario is not None:
        degree = scenario.observability
    if degree is not None and not gridmap.marked:
        raise UsageError(
            f"--observability: the map {args.map} does not mark L's start; show a scenario "
            "(.toml) that gives it in [observer]"
        )
    mask = gridmap.visible_mask(degree) if degree is not None else None
    rows, cols = gridmap.shape
    if not args.png or (rows <= TEXT_MAP_LIMIT[0] and cols <= TEXT_MAP_LIMIT[1]):
        print(map_to_text(gridmap, mask))
    for line in _map_summary(gridmap, mask, degree):
        print(line)
    routes = {}
    if scenario is not None:
        for i, name in enumerate(scenario.robot_names):
            routes[name] = scenario.patrol_route(i)
        print(*_scenario_summary(scenario, routes), sep="\n")
    if args.png:
        save_map_png(gridmap, args.png, observability=degree, routes=routes)
        print(f"wrote {args.png}")
    return 0


def _names_a_scenario_only(name: str) -> bool:
    """Whether ``name`` is a shipped scenario's and no shipped map's: ``show-map office`` shows
    the floor `mirl run --scenario office` runs on (office-60x60-s2), not the generated map the
    bare name ``office`` would also name (office-60x60-s0, another floor)."""
    from mirl.world.catalog import shipped_maps
    from mirl.world.scenario import shipped_scenarios

    return name in shipped_scenarios() and name not in shipped_maps()


def _map_summary(gridmap, mask, degree) -> list[str]:
    """What show-map says of a map: cells, states, frame and L's view."""
    import numpy as np

    n = gridmap.n_patroller_cells
    rows, cols = gridmap.shape
    f = gridmap.frame
    lines = [
        f"{gridmap.name}: {rows}x{cols} cells of {f.cell_size:g} m, {n} patroller cells, "
        f"{4 * n} patroller states (cell x heading)"
    ]
    (x0, x1), (y1, y0) = f.cell_centre(np.array([0, rows - 1]), np.array([0, cols - 1]))
    half = f.cell_size / 2
    lines.append(
        f"  frame: cell (0, 0) is centred at x = {float(x0):g}, y = {float(y1):g} m; the grid "
        f"spans x {float(x0) - half:g} to {float(x1) + half:g} m, "
        f"y {float(y0) - half:g} to {float(y1) + half:g} m"
    )
    if not gridmap.marked:
        lines.append("  L's start and goal: not marked (a scenario gives them in [observer])")
    if mask is not None:
        k = int(mask.sum())
        sight = int((mask & gridmap.in_line_of_sight()).sum())
        lines.append(
            f"  L's view at observability {degree:g}: {k} of {n} patroller cells, {sight} of "
            "them in L's line of sight"
            + ("" if sight == k else " (the others stand for cameras elsewhere)")
        )
    return lines


def _scenario_summary(scenario, routes) -> list[str]:
    f = scenario.map.frame
    lines = [f"scenario {scenario.name}:"]
    for what, cell in (("start", scenario.observer_start), ("goal", scenario.goal)):
        x, y = f.cell_centre(*cell)
        lines.append(f"  L's {what}: cell {tuple(cell)}, x = {float(x):g}, y = {float(y):g} m")
    for robot, (name, route) in zip(scenario.robots, routes.items(), strict=True):
        r, c, h = robot.start
        lines.append(
            f"  {name}: starts on cell ({r}, {c}) facing {HEADING_NAMES[h]}; its true policy "
            f"covers {len({tuple(x) for x in route.tolist()})} cells"
        )
    return lines


@command("simulate")
def _simulate(args: argparse.Namespace) -> int:
    check_pose_flags(args)
    outputs = (("--observations", args.observations), ("--truth", args.truth))
    check_distinct(*outputs, ("--poses", args.poses))
    for flag, path in outputs:
        if path:
            check_csv_output(path, flag)
    check_poses_output(args.poses, args.world)
    scenario = _load_scenario(args)
    world = _world(args.world).load()
    start, cpu = time.perf_counter(), time.process_time()
    sim = world.simulate(
        scenario,
        args.steps,
        seed=args.seed,
        observability=args.observability,
        heading_noise=args.heading_noise,
        random_starts=args.random_starts,
    )
    elapsed, cpu = time.perf_counter() - start, time.process_time() - cpu
    # the files first, then what was done: a reader that leaves early (`| head -3`) stops the
    # printing, not the record the user asked for
    wrote = []
    if args.observations:
        sim.observations.to_csv(args.observations)
        wrote.append(f"wrote {args.observations} ({len(sim.observations)} rows)")
    if args.truth:
        sim.truth.to_csv(args.truth)
        wrote.append(f"wrote {args.truth} ({len(sim.truth)} rows)")
    if args.poses and sim.poses is not None:
        wrote.append(_write_measured_poses(Path(args.poses), sim.poses))
    elif args.poses:
        wrote.append(_write_poses(args, scenario, sim.observations))
    print(*_simulation_summary(scenario, sim, args.seed, elapsed, cpu), *wrote, sep="\n")
    return 0


def _simulation_summary(scenario, sim, seed: int, elapsed: float, cpu: float) -> list[str]:
    """What ``mirl simulate`` says of a simulation: the scenario and what the world ran with,
    the steps (and the simulated time, for a world with a clock), L's view, how often L saw
    each patroller, the world's own counts and the time it took."""
    conditions = f" ({sim.conditions})" if sim.conditions else ""
    clock = sim.step_seconds is not None
    simulated = (sim.steps - 1) * sim.step_seconds if clock else 0.0
    minutes = f" ({simulated / 60:.1f} min)" if clock else ""
    cells = int(scenario.map.visible_mask(sim.observability).sum())
    lines = [
        f"scenario {scenario.name}{conditions}: {sim.steps} steps{minutes}, seed {seed}, "
        f"observability {sim.observability:g} ({cells}/{scenario.map.n_patroller_cells} cells)"
    ]
    for name, share in zip(scenario.robot_names, sim.observed_share(), strict=True):
        lines.append(f"  {name}: observed {share:.1%} of steps")
    lines += [f"  {line}" for line in sim.report]
    factor = f" (real-time factor {simulated / max(cpu, 1e-9):.0f} on CPU time)" if clock else ""
    lines.append(f"  simulated in {elapsed:.3f} s wall, {cpu:.3f} s CPU{factor}")
    return lines


def _write_measured_poses(out: Path, poses) -> str:
    """``--poses OUT`` of a world that measures poses itself: what L's sensor measured to
    ``OUT``, the true poses beside it (``.true`` before the suffix); the line that says so."""
    from mirl.observations.poses import write_pose_csv

    if out.suffix.lower() == ".csv":  # .csv or .mcap: checked before the simulation
        write = write_pose_csv
    else:
        from mirl.observations.bags import write_mcap as write
    true_out = out.with_name(out.stem + ".true" + out.suffix)
    write(poses.observed, out)
    write(poses.true, true_out)
    return (
        f"wrote {out} ({len(poses.observed)} poses L's camera measured, one per seen patroller "
        f"per step) and {true_out} ({len(poses.true)} true poses at {poses.true_rate_hz:g} Hz)"
    )


def _write_poses(args: argparse.Namespace, scenario, observations) -> str:
    """``--poses OUT`` from grid observations
    (:func:`~mirl.observations.discretise.poses_from_trajectories`); the line that says so."""
    from pathlib import Path

    from mirl.observations.bags import write_mcap
    from mirl.observations.discretise import poses_from_trajectories
    from mirl.observations.poses import write_pose_csv

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
    out = Path(args.poses)  # its kind was checked before the simulation (check_poses_output)
    if out.suffix.lower() == ".csv":
        write_pose_csv(tracks, out)
        what = "pose CSV"
    else:
        write_mcap(tracks, out)
        what = "MCAP, topics /ROBOT/pose"
    return (
        f"wrote {out} ({len(tracks)} poses, {what}, {args.pose_rate:g} Hz, steps of "
        f"{args.step_seconds:g} s from t = 0; noise {sigma_m:g} m / {sigma_deg:g} deg)"
    )


def _read_observations(args: argparse.Namespace, scenario, observability=None):
    from mirl.observations.sources import load_observations

    loaded = load_observations(
        args.observations,
        scenario,
        topics=[parse_topic(t) for t in args.topic or []],
        step_seconds=args.step_seconds,
        start_time=args.start_time,
        tolerance=args.tolerance,
        drop_off_map=args.drop_off_map,
        visible=args.visible,
        observability=observability,
        same_frames=dict(parse_same_frame(t) for t in getattr(args, "same_frame", None) or []),
    )
    if loaded.left_out:  # said, not dropped silently: a robot may be missing from --topic
        robots = ", ".join(f"{name} ({n} poses)" for name, n in loaded.left_out.items())
        warn(f"{args.observations}: not read, as no --topic names them: {robots}")
    return loaded


@command("convert")
def _convert(args: argparse.Namespace) -> int:
    from mirl.learning.verdicts import record_off_pace

    check_distinct(("IN", args.input), ("OUT", args.output))
    check_csv_output(args.output, "OUT")
    check_damage("convert", args)
    scenario = _load_scenario(args)
    args.observations = args.input
    loaded = _read_observations(args, scenario)
    # an empty record is never what a conversion is for
    _check_placed(args.input, loaded, "convert", args.start_time)
    loaded.trajectories.to_csv(args.output)
    traj, domain = loaded.trajectories, scenario.domain
    series = [traj.state_series(domain, i) for i in range(len(traj.robot_names))]
    off_pace = record_off_pace(domain, traj, series)
    if off_pace:  # the grid CSV keeps states, not the times that tell it
        warn(
            f"{args.input}: {off_pace}; {args.output} keeps the cells, not "
            f"the poses' times, so a verdict learned from it cannot know this: learn from "
            f"{args.input} itself"
        )
    if loaded.discretised is not None:
        print(f"{args.input}: " + loaded.discretised.summary())
    else:
        print(f"{args.input}: grid observations, {loaded.trajectories.horizon} steps")
    print(f"wrote {args.output} ({len(loaded.trajectories)} rows)")
    return 0


def _check_placed(path, loaded, purpose: str, start_time: float | None) -> None:
    """Refuse robot data of which no pose became an observation, saying why: a --start-time
    after every pose by the last pose's time, else by the drops counted and the watch; grid
    data with no rows is :func:`check_observations`'s."""
    if len(loaded.trajectories):
        return
    d = loaded.discretised
    if d is None:  # grid data: learning's own check says it has no rows
        if purpose == "convert":
            raise UsageError(f"{path}: nothing to convert: it has a header and no rows")
        return
    if start_time is not None and d.last_pose is not None and start_time > d.last_pose:
        # "no step within the tolerance" would not say it was the flag
        raise UsageError(
            f"{path}: nothing to {purpose}: --start-time {_seconds(start_time)} s is after "
            f"every pose (the last at t = {_seconds(d.last_pose)} s)"
        )
    why = _nothing_placed(d.report) + f" ({d.summary().splitlines()[0]})"
    raise UsageError(f"{path}: nothing to {purpose}: {why}")


def _seconds(t: float) -> str:
    """A time in seconds to the millisecond, without trailing zeros: 100000, 899.9,
    1700000000.25 (``:g`` would round an epoch time to 1.7e+09)."""
    return f"{t:.3f}".rstrip("0").rstrip(".")


def _nothing_placed(report) -> str:
    """Why no pose of a record became an observation, by the drop reasons counted."""
    drops: dict[str, int] = {}
    for r in report:
        for why, n in r.drops().items():
            drops[why] = drops.get(why, 0) + n
    total = sum(r.read + r.unplaced for r in report)
    reasons = ", ".join(f"{n} {why}" for why, n in drops.items() if n)
    return f"none of its {total} poses was placed on a step and cell: dropped {reasons or 'none'}"


@command("learn-transitions")
def _learn_transitions(args: argparse.Namespace) -> int:
    from mirl.learning.options import LABELLINGS
    from mirl.learning.transitions import (
        TransitionFeatureLearner,
        observed_steps,
        perception_labels,
    )

    check_damage("learn-transitions", args)
    scenario = _load_scenario(args)
    domain = scenario.domain
    loaded = _read_observations(args, scenario)
    _check_placed(args.observations, loaded, "learn from", args.start_time)
    obs = loaded.trajectories
    check_observations(args.observations, obs, domain)
    series = [obs.state_series(domain, i) for i in range(len(scenario.robots))]
    labels = LABELLINGS[args.labels].load()(scenario, series)
    _say_placed(args, loaded)
    learned = {}
    for i, name in enumerate(scenario.robot_names):
        t, s, s_next = observed_steps(series[i])
        a = labels[i][t].copy()
        a[perception_labels(domain, s, s_next) < 0] = -1  # no trial of any part
        learned[name] = TransitionFeatureLearner(domain, scenario.error_model).fit(s, a, s_next)
    if args.json:
        print_json({n: m.feature_probabilities_ for n, m in learned.items()})
        return 0
    features = domain.feature_map.features
    print(f"learned transition-feature probabilities ({args.labels} labels, {args.observations})")
    print(f"{'robot':<6}" + "".join(f"{f:>13}" for f in features) + f"{'steps':>8}")
    thin: list[str] = []
    for name, m in learned.items():
        probs = m.feature_probabilities_
        lowest = unique_lowest(probs)
        cells = "".join(f"{probs[f]:>12.3f}{'*' if f == lowest else ' '}" for f in features)
        print(f"{name:<6}{cells}{int(m.counts_.trials.sum()):>8}")
        if lowest is None:
            print(f"  no single lowest feature ({min(probs.values()):.3f} is shared)")
        if not m.result_.success:
            print(f"  note: {m.result_.message}")
        trials = feature_trials(m.counts_)
        thin += [f"{name}:{f} ({trials[f]})" for f in features if trials[f] < MIN_TRIALS]
    print("* lowest feature of the robot; uninformed features get 0.5 (maximum entropy)")
    if thin:
        warn(
            f"{args.observations}: fewer than {MIN_TRIALS} observed trials behind "
            + ", ".join(thin)
            + " — those probabilities are barely informed"
        )
    return 0


@command("experiment")
def _experiment(args: argparse.Namespace) -> int:
    from mirl.experiments.conditions import get_experiment, in_world, with_em_init, with_protocol
    from mirl.experiments.sweep import run_experiment

    check_experiment_flags(args)
    options = _options(args, SweepOptions)
    _world(options.world)
    exp = get_experiment(args.name)
    # the grid as the sweep will run it, refused here before anything is created
    in_world(with_protocol(with_em_init(exp, options.em_init), options.go_rule, options.relearn),
             options.world)  # fmt: skip
    suffix = "" if options.world == DEFAULT_WORLD else f"-{options.world}"
    out = args.out or f"results/{exp.name}{suffix}"
    summary = run_experiment(exp, out, options)
    from mirl.viz.report import write_report_and_figures

    written = write_report_and_figures(out)
    figures = (
        f" and {len(written.figures)} figure files in {out}/figures/ (`mirl report {out}` "
        "redraws them)"
        if written.figures
        else " (no figures: the experiment has none to draw)"
    )
    print(f"wrote {out}/results.sqlite, {out}/results.csv, {written.report}{figures}")
    return 1 if summary.outcomes.get("error") else 0


@command("report")
def _report(args: argparse.Namespace) -> int:
    from mirl.viz.report import write_report_and_figures

    written = write_report_and_figures(args.dir)
    print(f"wrote {written.report}")
    for figure in written.figures:
        print(f"wrote {figure}")
    if not written.figures:
        print("(no figures: no experiment here has one to draw)")
    return 0


@command("run")
def _run(args: argparse.Namespace) -> int:
    from mirl.experiments.episode import run_episode
    from mirl.experiments.run_report import format_report

    if args.plot:  # before the run: a bad path must not cost a run
        check_output(args.plot, "--plot", FIGURE_SUFFIXES)
    if args.animate:
        check_output(args.animate, "--animate", (".gif",))
    check_distinct(("--plot", args.plot), ("--animate", args.animate))
    learning = _options(args, LearnOptions)
    learning.check_method(args.method, _given(args, LearnOptions))
    if args.obs_steps is not None and args.watch_until_seen is not None:
        raise UsageError("--obs-steps (a fixed time) and --watch-until-seen exclude each other")
    protocol = _options(args, RunProtocol)
    protocol.check_method(args.method, _given(args, RunProtocol))
    if args.obs_steps is not None:  # a fixed observation time, as the experiments have
        protocol = protocol.replace(watch_until_seen=None)
    scenario = _load_scenario(args)
    _check_cost(args, scenario, "run", protocol.obs_steps)
    result = run_episode(
        scenario,
        args.method,
        seed=args.seed,
        observability=args.observability,
        protocol=protocol,
        learn_options=learning,
        world=args.world,
    )
    if args.json:
        print_json(result.to_dict())
    else:
        print(format_report(scenario, result))
    if args.plot:
        from mirl.viz.runs import save_run_png

        try:
            save_run_png(scenario, result, args.plot)
        except Exception as exc:  # the report is already out; say why the drawing is not
            raise UsageError(f"--plot {args.plot}: drawing failed ({exc})") from None
        if not args.json:
            print(f"wrote {args.plot}")
    if args.animate:
        from mirl.viz.animation import save_run_animation

        save_run_animation(scenario, result, args.animate)
        if not args.json:
            print(f"wrote {args.animate}")
    return 0


@command("learn")
def _learn(args: argparse.Namespace) -> int:
    from mirl.cli.learn_report import learn_record, pace_record, poses_record, print_learn
    from mirl.learning.learn import learn

    options = _options(args, LearnOptions)
    options.check_method(args.method, _given(args, LearnOptions))
    scenario = _load_scenario(args)
    degree = scenario.observability if args.observability is None else args.observability
    loaded = _read_observations(args, scenario, observability=args.observability)
    obs = loaded.trajectories
    truth = _scored_against_truth(args, loaded.kind)
    check_damage("learn", args, scored=truth)  # robot data's kind is known once it is read
    _check_placed(args.observations, loaded, "learn from", args.start_time)
    check_observations(args.observations, obs, scenario.domain)
    estimate = _check_cost(args, scenario, "learn", obs.horizon)
    from mirl.experiments.cost import LONG_SECONDS

    if estimate.seconds > LONG_SECONDS and len(obs):  # say a long wait before it starts
        warn(
            f"{args.observations}: learning a record of {obs.horizon:,} steps (rows from t = "
            f"{int(obs.t.min())} to {int(obs.t.max())}) on {estimate.describe()}"
        )
    visible = loaded.visible_states(scenario)
    if visible is None:  # grid data (pose data's summary counts the rows outside the view)
        seen = scenario.domain.visible_states(degree)
        check_visible(args.observations, obs, scenario.domain, seen, degree)
    result = learn(
        obs,
        scenario,
        args.method,
        options=options,
        visible=visible,
        observability=degree,
        random_state=args.seed,
        score=truth,
    )
    agreement = None
    if not truth:  # robot data: the scenario is the user's description, not a truth
        from mirl.learning.results import observed_agreement

        agreement = {
            r.name: observed_agreement(
                scenario.domain, obs.state_series(scenario.domain, i), r.policy
            )
            for i, r in enumerate(result.robots)
        }
    if args.visible == "observed" and visible is not None:
        # the view learned under is the cells the robots were seen on, not the degree's
        degree = float(visible.mean())
    out = learn_record(result, scenario, str(args.observations), obs.horizon, degree, agreement)
    if args.visible == "observed":
        out["visible"] = "observed"
    out.update(pace_record(loaded.discretised))
    out.update(poses_record(loaded.discretised))
    if args.json:  # the summary's counts, as `poses` (poses_record)
        print_json(out)
    else:
        _say_placed(args, loaded)
        print_learn(out, result, scenario)
    return 0


def _say_placed(args: argparse.Namespace, loaded) -> None:
    """Pose data's discretisation summary (the step chosen, each robot's poses read, binned,
    snapped and dropped by reason), never left out: on stdout before a text report, on stderr
    beside ``--json``'s one object where that has no place for it (``learn-transitions``)."""
    if loaded.discretised is not None:
        print(
            f"{args.observations}: " + loaded.discretised.summary(),
            file=sys.stderr if args.json else sys.stdout,
        )


def _scored_against_truth(args: argparse.Namespace, kind: str) -> bool:
    """Whether ``learn`` scores against the scenario's truth (docs/design.md, "Reports on data
    without a truth"): ``--compare truth`` or ``observed``, or by default for mirl's grid CSVs
    only — what ``mirl simulate`` writes — and never for robot data (bags, pose CSVs)."""
    if args.compare != "auto":
        return args.compare == "truth"
    from mirl.observations.sources import ROBOT_DATA_KINDS

    return kind not in ROBOT_DATA_KINDS


def _check_cost(args: argparse.Namespace, scenario, command: str, steps: int):
    """Refuse at once, in one line, a command whose estimated memory exceeds --max-memory
    (docs/design.md, "Cost before work"); the estimate otherwise."""
    from mirl.experiments.cost import check_budget, default_max_memory, estimate_cost

    budget = args.max_memory if args.max_memory is not None else default_max_memory()
    estimate = estimate_cost(scenario, command, steps=steps)
    check_budget(scenario, estimate, budget)
    return estimate


def _options(args: argparse.Namespace, options: type[OptionsT]) -> OptionsT:
    """The ``options`` of a command: each option whose flag the command has and the user gave
    (a flag left out leaves the declared default)."""
    given = {
        name: getattr(args, name)
        for name in options.__options__
        if getattr(args, name, None) is not None
    }
    return options(**given)


def _given(args: argparse.Namespace, options: type[Options]) -> list[str]:
    """The options of ``options`` that some method does not read (their check needs to know)
    whose flag the user gave, in their declared order: the parser leaves such a value flag
    None when it is left out (:func:`mirl.cli.parser._option`), and a switch given turns its
    declared default over. A default never counts as given."""
    from mirl.learning.methods import ruled_options

    ruled = ruled_options()
    return [
        name
        for name, spec in options.__options__.items()
        if name in ruled
        and getattr(args, name, None) is not None
        and (not isinstance(spec.default, bool) or getattr(args, name) != spec.default)
    ]


def print_json(obj) -> None:
    """Print ``obj`` as indented JSON, its keys in the order given.

    Parameters
    ----------
    obj : object
        Anything :func:`json.dumps` writes (the records' ``to_dict()``).
    """
    print(json.dumps(obj, indent=2, sort_keys=False))
