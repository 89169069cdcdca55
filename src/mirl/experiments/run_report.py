"""The readable report of `mirl run`: what L saw, what it learned of each robot, what it decided,
and how the run ended."""

from __future__ import annotations

import numpy as np

from mirl.experiments.records import RunResult
from mirl.learning.methods import METHODS
from mirl.learning.verdicts import estimate_disagrees, untested_words
from mirl.world.actions import HEADING_NAMES, STEP_SECONDS
from mirl.world.game import GAME_ACTIONS, Equilibrium
from mirl.world.scenario import Scenario


def state_text(state) -> str:
    """A patroller state (row, col, heading) in words: ``(16, 8) facing west``.

    Parameters
    ----------
    state : sequence of int
        (row, col, heading), a heading an index into the domain's headings.

    Returns
    -------
    str
        The state in words.
    """
    r, c, h = (int(x) for x in state)
    return f"({r}, {c}) facing {HEADING_NAMES[h]}"


def _observed_line(result: RunResult) -> str:
    seen = "; ".join(f"saw {n} on {k} steps" for n, k in result.seen_steps.items())
    minutes = result.obs_steps * STEP_SECONDS / 60
    line = f"observed  {result.obs_steps} steps ({minutes:.0f} min of robot time): {seen}"
    k = result.watch_until_seen
    if k is None or result.protocol is None:
        return line
    first = result.protocol.obs_steps
    if min(result.seen_steps.values(), default=0) >= k and result.obs_steps > first:
        why = f"L watched past {first} steps until it had seen every patroller on {k} steps"
    elif min(result.seen_steps.values(), default=0) >= k:
        why = f"every patroller was seen on {k} steps within the first {first}"
    else:
        why = f"L stopped at its watching limit before seeing every patroller on {k} steps"
        never = [n for n, c in result.seen_steps.items() if c == 0]
        if never:  # a route that may never cross L's view: say how to avoid the long wait
            why += (
                f"; {', '.join(never)} never came into view — `--obs-steps N` watches a fixed time"
            )
    return f"{line}\n          ({why})"


def _wrapped(text: str, indent: int = 10, label: str = "") -> str:
    import textwrap

    return textwrap.fill(
        text, 96, initial_indent=label.ljust(indent), subsequent_indent=" " * indent
    )


def _equilibrium_text(eq: Equilibrium, a: str, b: str) -> str:
    """What the learned interaction equilibrium ``eq`` means for robots ``a`` (the row side) and
    ``b`` meeting head-on; a mixed one names only the actions each robot plays."""
    if not eq.is_pure:
        return "a mixed strategy when they meet: " + "; ".join(
            f"{name} {_mix(p)}" for name, p in ((a, eq.row), (b, eq.col))
        )
    i, j = (GAME_ACTIONS[int(np.argmax(p))] for p in (eq.row, eq.col))
    if i == "stop" and j == "go":
        return f"when {a} and {b} meet, {a} yields (stops) and {b} goes on"
    if i == "go" and j == "stop":
        return f"when {a} and {b} meet, {b} yields (stops) and {a} goes on"
    return f"when {a} and {b} meet, {a} plays {i} and {b} plays {j}"


def _mix(p) -> str:
    """A robot's strategy in words: each action it plays with its probability."""
    played = [(GAME_ACTIONS[k], x) for k, x in enumerate(p) if x > 1e-9]
    if len(played) == 1:
        return f"always plays {played[0][0]}"
    return "plays " + " or ".join(f"{act} with probability {x:.2f}" for act, x in played)


def _equilibrium_lines(learned, names: list[str]) -> list[str]:
    """The learned interaction, in the scenario's robot names: for a pair its equilibrium; for a
    team each pair L weighed on its own (the pairs it saw meet) and the team's equilibrium,
    which L's model lets every other pair play (``LearnResult.pair_equilibrium``), or, where L
    saw no pair meet, the team's equilibrium alone."""
    pad = "          "
    if len(names) == 2:
        label = learned.equilibrium.label()
        text = _equilibrium_text(learned.equilibrium, *names)
        return [f"{pad}interaction equilibrium ({names[0]}/{names[1]}): {label} — {text}"]
    lines = []
    for (i, j), eq in sorted(learned.pair_equilibria.items()):
        label = eq.label()
        text = _equilibrium_text(eq, names[i], names[j])
        lines.append(f"{pad}interaction equilibrium ({names[i]}/{names[j]}): {label} — {text}")
    weighed = ", ".join(f"{names[i]}/{names[j]}" for i, j in sorted(learned.pair_equilibria))
    if not weighed:  # meeting_pairs' fallback: the first pair, on the steps L did not see
        lines.append(
            f"{pad}every pair: the team's equilibrium {learned.equilibrium.label()} (L saw no "
            f"pair meet; weighed on what it did not see of {names[0]}/{names[1]}; the earlier "
            "robot of a pair plays the row side)"
        )
        return lines
    lines.append(
        f"{pad}other pairs: the team's equilibrium {learned.equilibrium.label()} (weighed on "
        f"{weighed}; the earlier robot of a pair plays the row side)"
    )
    return lines


# ---- the readable report of `mirl run` -------------------------------------------------------
def policy_cycle(domain, policy: np.ndarray, start: int) -> np.ndarray:
    """States of the loop that ``policy`` settles into from ``start`` under intended outcomes.

    Parameters
    ----------
    domain : PatrolDomain
        The domain (its intended next states).
    policy : ndarray of shape (S,) of int
        A deterministic policy.
    start : int
        The state to start from.

    Returns
    -------
    ndarray of int
        The loop's states in order, from where the walk first met it.
    """
    s = int(start)
    for _ in range(domain.n_states):  # walk long enough to be on the loop
        s = int(domain.intended[s, policy[s]])
    cycle = [s]
    s = int(domain.intended[s, policy[s]])
    while s != cycle[0]:
        cycle.append(s)
        s = int(domain.intended[s, policy[s]])
    return np.asarray(cycle)


def _turn_cells(domain, cycle: np.ndarray) -> list[tuple[int, int]]:
    """Cells where the loop reverses direction (heading turned by 180° across a stay)."""
    rch = domain.states[cycle]
    out: list[tuple[int, int]] = []
    for i in range(len(cycle)):
        a, b = rch[i], rch[(i + 2) % len(cycle)]
        cell = (int(a[0]), int(a[1]))
        if (a[2] - b[2]) % 4 == 2 and (a[0], a[1]) == (b[0], b[1]) and cell not in out:
            out.append(cell)
    return out


def _truth(scenario: Scenario, result: RunResult) -> str:
    """What is really damaged: in the grid world the success probabilities the scenario's
    definition of damage (``[faults]``, the one the verdicts are held against) counts as
    damaged; in the physics world the motor strengths the robots drive with (the grid
    probabilities are then only what the scenario would mean on the grid, not what L
    watches)."""
    world_truth = result.extras.truth() if result.extras is not None else None
    if world_truth is not None:
        return world_truth
    damaged = [
        f"{r.name}:{f}={p:g}"
        for r in scenario.robots
        for f, p in r.feature_probabilities.items()
        if scenario.faults.damaged(f, p)
    ]
    return f"truth: {', '.join(damaged) or 'no damage'}"


def _feature_table(scenario: Scenario, result: RunResult, learned) -> list[str]:
    """Each robot's learned feature probabilities, their 95 % intervals, the motion model and
    the verdict — one answer per question: where Eq. 4's estimate lies outside its interval,
    the posterior's median is the answer and Eq. 4's is shown as the paper's estimate, which L
    plans with (docs/design.md, "Fault verdicts")."""
    feats = list(scenario.feature_map.features)
    lines = [f"learned   transition-feature probabilities ({learned.method}):"]
    lines.append("            robot" + " " * 11 + "".join(f"{f:>13}" for f in feats))
    models = {r.name: r for r in learned.robots}
    outside = False
    for name, fp in result.feature_probabilities.items():
        r = models[name]
        spans = r.feature_intervals
        u = r.uncertainty
        unseen = " (never seen: maximum entropy)" if result.seen_steps.get(name) == 0 else ""
        if spans and u is not None and estimate_disagrees(fp, spans, u.medians, scenario.faults):
            outside = True
            lines.append(f"            {name:<5}{'posterior':<11}" + _cells(u.medians, feats, 2))
            lines.append(f"            {'':<5}{'95 %':<11}" + _spans(spans, feats))
            lines.append(f"            {'':<5}{'Eq. 4':<11}" + _cells(fp, feats, 3) + unseen)
            continue
        lines.append(f"            {name:<5}{'':<11}" + _cells(fp, feats, 3) + unseen)
        if spans:
            lines.append(f"            {'':<5}{'95 %':<11}" + _spans(spans, feats))
    note = (
        "            (each is how often an action that relies on the part does what was "
        "intended; below it, its 95 % interval"
    )
    if outside:
        note += (
            "; where Eq. 4's estimate, from the step outcomes alone, and the posterior disagree "
            "(outside the interval, or on the other side of the damage threshold), the "
            "posterior's median is the answer and Eq. 4's the paper's estimate, which L plans "
            "with"
        )
    lines += _wrapped(note.strip() + ")", indent=12).splitlines()
    for r in learned.robots:
        if r.lateral_drift is not None:
            lines.append(f"          drift of {r.name}: {r.lateral_drift.sentence()}")
    for r in learned.robots:
        if r.uncertainty is not None and r.uncertainty.untested:
            lines.append(f"          {r.name}'s {untested_words(r.uncertainty.untested)}")
    for r in learned.robots:
        motion = _motion_words(r)
        if motion:
            lines += _wrapped(f"motion of {r.name}: {motion}").splitlines()
    for r in learned.robots:
        if r.verdict is not None:
            lines.append(f"          verdict: {r.verdict.sentence(r.name)}")
    return lines


def _cells(values, feats, digits: int) -> str:
    return "".join(f"{values[f]:>13.{digits}f}" for f in feats if f in values)


def _spans(spans, feats) -> str:
    return "".join(f"{f'{spans[f][0]:.2f}–{spans[f][1]:.2f}':>13}" for f in feats)


def _motion_words(robot) -> str:
    """The motion model L plans with and the records' weights, in words."""
    from mirl.learning.motion_models import motion_sentence

    u = robot.uncertainty
    if u is None or not u.motion_models or not robot.motion_model:
        return ""
    return motion_sentence(u.motion_models, robot.motion_model)


def _relearn_lines(result: RunResult) -> list[str]:
    """What re-learning while L waited changed (nothing when L learned once)."""
    if result.relearns is None:
        return []
    if not result.relearns:
        return ["relearned never while waiting (its record did not grow enough before it went)"]
    steps = ", ".join(str(r.t) for r in result.relearns)
    last = result.relearns[-1]
    acc = (
        ""
        if last.behavior_accuracy is None
        else f", behaviour accuracy {last.behavior_accuracy:.2f}"
    )
    lines = [f"relearned {len(result.relearns)} times while waiting (t = {steps}), warm-started"]
    lines.append(
        f"          last on {last.observed_steps} observed steps{acc} "
        "(the models and verdicts above are the last ones)"
    )
    return lines


def format_report(scenario: Scenario, result: RunResult) -> str:
    """The short readable report printed by ``mirl run``.

    Parameters
    ----------
    scenario : Scenario
        The run's scenario, as run (its damage applied).
    result : RunResult
        The run.

    Returns
    -------
    str
        The report's lines, joined (the timings' line last).
    """
    dom = scenario.domain
    paper, meaning = METHODS[result.method].paper_name, METHODS[result.method].description
    n_vis = int(scenario.map.visible_mask(result.observability).sum())
    lines = [
        f"mirl run: scenario {scenario.name} ({_truth(scenario, result)}), "
        f"method {result.method}, observability {result.observability:g} "
        f"({n_vis}/{scenario.map.n_patroller_cells} cells), seed {result.seed}",
        _wrapped(
            f"{result.method} ({paper} in the paper's figures): {meaning}. {_waits(scenario)} "
            f"and wants to reach {scenario.goal} unseen; cells "
            "are (row, col), a patroller's state is its cell and the way it faces; a step is "
            f"{STEP_SECONDS:g} s."
        ),
        "",
        _observed_line(result),
    ]
    if result.extras is not None:  # a world's own word on its run (one outside its calibration)
        lines += [_wrapped(note, label="world") for note in result.extras.notes()]
    learned = result.learned
    has_features = any(result.feature_probabilities.values())
    if learned is not None and not has_features:
        lines.append(f"learned   no feature probabilities: {learned.message or learned.method}")
    if learned is not None and has_features:
        lines += _feature_table(scenario, result, learned)
    if learned is not None:
        acc = ", ".join(f"{n} {a:.2f}" for n, a in result.behavior_accuracy_per_robot.items())
        lines.append(f"          behaviour accuracy: {acc} (mean {result.behavior_accuracy:.2f})")
        for i, r in enumerate(learned.robots):
            start = dom.state_index(*scenario.robots[i].start)
            cyc = policy_cycle(dom, r.policy, int(start))
            true = set(policy_cycle(dom, scenario.true_policy(i), int(start)).tolist())
            same = "the true patrol" if set(cyc.tolist()) == true else "differs from the truth"
            ends = " and ".join(str(c) for c in _turn_cells(dom, cyc))
            where = f"turning around at {ends}" if ends else "without turning around"
            lines.append(f"          patrol of {r.name}: a {len(cyc)}-step loop {where} ({same})")
        lines += _equilibrium_lines(learned, list(scenario.robot_names))
    lines += _relearn_lines(result)
    if result.go_time is None:
        lines.append(
            f"planned   {len(result.attempts)} rounds, no go time with a positive value "
            f"(best {max(a.best_value for a in result.attempts):.2f})"
            if result.attempts
            else "planned   -"
        )
    elif result.plan_value is None:
        lines.append(f"went      at t={result.go_time} (a random time)")
    elif result.predicted_success is not None:
        lines += _stated_lines(result)
    else:
        lines.append(
            f"went      at t={result.go_time}, {result.go_time - (result.obs_steps - 1)} steps "
            f"after observing, plan value {result.plan_value:.2f} ({len(result.attempts)} planning "
            "rounds)"
        )
        lines.append(
            "          (value = predicted P(goal reached unseen) - 0.5 x P(seen first); "
            "L goes when > 0)"
        )
    outcome = {
        "success": f"success — reached the goal {scenario.goal} unseen at t={result.end_time}",
        "detected": "detected — "
        + "; ".join(
            f"{d.robot} at {state_text(d.robot_state)} saw L on {d.observer_cell} at t={d.t}"
            for d in result.detections
        ),
        "timeout": f"timeout — no safe go time before t={result.end_time}",
    }[result.outcome]
    lines.append(f"outcome   {outcome}")
    tm = result.timings
    lines.append(
        "time      "
        + ", ".join(f"{k} {tm[k]:.2f} s" for k in ("observe", "learn", "plan", "execute"))
        + f"; total {tm['total']:.2f} s"
    )
    return "\n".join(lines)


def _waits(scenario: Scenario) -> str:
    """Where L waits, in words: its room, or — on a map with no room there, as a ROS map's — a
    hallway cell the patrollers may cross, where nothing detects it before it goes: detection
    is scored from the go time, as in the paper, whose L waits in a room."""
    start = scenario.observer_start
    if start is not None and scenario.map.patroller[start[0], start[1]]:
        return (
            f"L waits at {scenario.observer_start}, a hallway cell (no room there; detection "
            "is scored only once L goes, as in the paper, where L waits in a room)"
        )
    return f"L hides in its room at {scenario.observer_start}"


def _stated_lines(result: RunResult) -> list[str]:
    """When L went and with what chance: averaged over model draws, with their spread and the
    point models' chance, where its models were drawn (docs/design.md, "The stated chance")."""
    assert result.go_time is not None and result.predicted_success is not None
    interval, point = result.predicted_success_interval, result.predicted_success_point
    lo, hi = interval if interval is not None else (result.predicted_success,) * 2
    drawn = lo < hi
    spread = f" (90 % of model draws: {lo:.2f}–{hi:.2f})" if drawn else ""
    averaged = result.predicted_success_averaged
    if averaged is not None:  # the draws' chances went through the method's calibration
        spread = f" ({lo:.2f}–{hi:.2f} over 90 % of its model draws)"
        how = (
            f"{averaged:.2f} averaged over model sets drawn from the posterior of its models, "
            f"stated through {METHODS[result.method].paper_name}'s calibration on held-out runs"
        )
    elif drawn:
        how = (
            "averaged over model sets drawn from the posterior of its models, not calibrated: "
            "no held-out map was fitted for this method, scenario, world, protocol and learning "
            "options"
        )
    else:
        how = "under its models and belief"
    if drawn and point is not None:
        how += f"; {point:.2f} under its point models alone"
    lines = [
        f"went      at t = {result.go_time} ({result.go_time - (result.obs_steps - 1)} steps "
        f"after observing, {len(result.attempts)} planning rounds), expecting to get through "
        f"with probability {result.predicted_success:.2f}{spread}",
        f"          (P(goal reached unseen) along its plan: {how}; L goes when its chance now "
        "beats what it can expect by waiting until its deadline)",
    ]
    fallbacks = result.filter_fallbacks
    if fallbacks:  # what L saw there contradicts its models: the user should know
        those = "that sighting" if fallbacks == 1 else "those sightings"
        lines.append(_wrapped(
            f"(on {fallbacks} of its steps up to then L saw what its models give probability "
            f"~0 — a move no learned action makes; its belief took {those} as seen, and the "
            "chance still rests on those models)"
        ))  # fmt: skip
    never = result.never_seen
    if never:  # the chance then rests on where L supposes them, which its record cannot check
        names = ", ".join(never)
        lines.append(_wrapped(
            f"(L had never seen {names} when it went: its chance takes "
            f"{'it' if len(never) == 1 else 'each'} to start anywhere out of view, with the "
            "reward of the robots it saw and a motion no record informs — an assumption nothing "
            "L saw can check; where a robot that never comes into view really patrols, the "
            "chance can be far off)"
        ))  # fmt: skip
    return lines
