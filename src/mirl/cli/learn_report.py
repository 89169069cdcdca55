"""What ``mirl learn`` reports: the record of a learned result (its ``--json`` output) and the
text form printed without ``--json``."""

from __future__ import annotations

from mirl.world.faults import WHEELS

__all__ = [
    "pace_record",
    "drift_line",
    "learn_record",
    "print_learn",
    "verdict_sentence",
    "feature_lines",
    "motion_line",
]


def verdict_sentence(robot: str, record: dict) -> str:
    """A verdict's JSON record (:meth:`~mirl.learning.verdicts.Verdict.to_dict`) in words.

    Parameters
    ----------
    robot : str
        The robot's name, as the sentence names it.
    record : dict
        The verdict's record: ``part``, ``confidence``, ``candidates`` and, where present,
        ``damage_probabilities`` (the parts damaged besides those named, :attr:`Verdict.also
        <mirl.learning.verdicts.Verdict.also>`, are read from them), ``fit`` (its ``ok`` and
        ``reason`` are read), ``seen_moving`` (default True) and ``weakened``.

    Returns
    -------
    str
        :meth:`~mirl.learning.verdicts.Verdict.sentence` of the verdict the record describes.
    """
    from mirl.learning.model_check import Check, ModelFit
    from mirl.learning.verdicts import TeamComparison, Verdict

    fit = None
    if "fit" in record:  # only its words are needed here
        fit = ModelFit((Check("record", record["fit"]["ok"], None, record["fit"]["reason"]),))
    verdict = Verdict(
        record["part"],
        record["confidence"],
        tuple(record["candidates"]),
        record.get("damage_probabilities", {}),
        fit=fit,
        seen_moving=record.get("seen_moving", True),
        weakened=record.get("weakened"),
        beside=TeamComparison.from_dict(record["beside"]) if "beside" in record else None,
    )
    return verdict.sentence(robot)


def learn_record(
    result, scenario, observations: str, steps: int, degree: float, agreement=None
) -> dict:
    """The JSON-ready record of a learned result (``mirl learn --json``).

    Parameters
    ----------
    result : LearnResult
        What was learned (:class:`~mirl.learning.results.LearnResult`).
    scenario : Scenario
        The scenario it was learned on.
    observations : str
        Where the observations came from, as the record names it (a path, say).
    steps : int
        The observations' length in steps.
    degree : float
        The observability they were taken at.
    agreement : dict of str to ObservedAgreement or None, default None
        Robot name -> :class:`~mirl.learning.results.ObservedAgreement`, given when the data
        has no truth: each robot's record then scores its policy against the observed moves
        only (``observed_moves``) and has no ``behavior_accuracy`` against the scenario.

    Returns
    -------
    dict
        ``method``, ``scenario``, ``observations``, ``steps``, ``observability`` (with
        ``--visible observed`` the share of the patrollers' states on the cells seen, and the
        caller adds ``visible``), ``robots``
        (per robot its weights, feature probabilities, behaviour accuracy and, where learned,
        intervals, medians, motion models and verdict), ``equilibrium`` (label, strategies and
        each candidate's weight), ``iterations``, ``label_changes``, ``pair_equilibria`` (teams
        of three or more), ``message`` and ``timings``; every value JSON-serialisable.
    """
    names = scenario.domain.reward_feature_names
    robots: dict[str, dict] = {
        r.name: {
            "weights": dict(zip(names, map(float, r.weights), strict=True)),
            "feature_probabilities": {k: float(v) for k, v in r.feature_probabilities.items()},
            "behavior_accuracy": r.behavior_accuracy,
            **_uncertainty(r),
        }
        for r in result.robots
    }
    for name, a in (agreement or {}).items():
        robots[name]["observed_moves"] = {
            "moves": a.moves,
            "followed": a.followed,
            "share": a.share,
            "unexplained": a.unexplained,
        }
    candidates = scenario.game.equilibria()
    eq_weights = result.equilibrium_weights or (None,) * len(candidates)
    return {
        "method": result.method,
        "scenario": scenario.name,
        "observations": observations,
        "steps": steps,
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
        **_pair_labels(result, scenario),
        "message": result.message,
        "timings": {k: round(v, 4) for k, v in result.timings.items()},
    }


def pace_record(discretised) -> dict:
    """The step pose data were read at, and how it was chosen.

    Parameters
    ----------
    discretised : Discretised or None
        The discretised pose data (:class:`~mirl.observations.discretise.Discretised`); None
        for grid data.

    Returns
    -------
    dict
        ``step_seconds`` and ``step_chosen`` (``"given"``, or the automatic choice in words);
        ``{}`` for grid data.
    """
    if discretised is None:
        return {}
    auto = discretised.auto_step
    return {
        "step_seconds": discretised.step_seconds,
        "step_chosen": "given" if auto is None else auto.sentence(),
    }


def poses_record(discretised) -> dict:
    """What became of pose data's poses: the counts of the text summary, for ``--json``.

    Parameters
    ----------
    discretised : Discretised or None
        The discretised pose data; None for grid data.

    Returns
    -------
    dict
        ``poses``: per robot the poses read, binned, snapped, the steps observed (and outside
        L's view) and the poses dropped by reason; ``{}`` for grid data.
    """
    if discretised is None:
        return {}
    return {
        "poses": {
            c.robot: {
                "read": c.read + c.unplaced,
                "binned": c.binned,
                "snapped": c.snapped,
                "observed_steps": c.observed_steps,
                "outside_visible": c.outside_visible,
                "dropped": {  # RobotCounts.drops()'s reasons
                    "off_map": c.dropped,
                    "no_step": c.no_step,
                    "duplicate": c.duplicates,
                    "unplaced": c.unplaced,
                },
            }
            for c in discretised.report
        }
    }


def drift_line(record: dict) -> str:
    """A lateral drift's JSON record (:meth:`~mirl.learning.verdicts.LateralDrift.to_dict`)
    in words.

    Parameters
    ----------
    record : dict
        The drift's record: ``mean``, ``se`` and ``steps``.

    Returns
    -------
    str
        The ``drift`` line of ``mirl learn``'s text output.
    """
    from mirl.learning.verdicts import LateralDrift

    drift = LateralDrift(record["mean"], record["se"], record["steps"])
    return f"drift         {drift.sentence()} (a robot veers towards a weak wheel)"


def _uncertainty(robot) -> dict:
    """``feature_intervals`` (95 %, [lo, hi]), ``feature_medians``, the motion models,
    the parts the steps cannot tell apart and ``verdict`` of a model that has them."""
    if robot.verdict is None:
        return {}
    u = robot.uncertainty
    out: dict = {
        "feature_intervals": {
            f: [round(float(lo), 4), round(float(hi), 4)]
            for f, (lo, hi) in robot.feature_intervals.items()
        }
    }
    if u is not None:
        out["feature_medians"] = {f: round(float(v), 4) for f, v in u.medians.items()}
        out["motion_model"] = robot.motion_model
        out["motion_models"] = {m: round(float(w), 4) for m, w in u.motion_models.items()}
        out["indistinguishable"] = [
            {
                "features": list(g),
                "told_apart_by": "drift" if u.sided_by_drift and set(g) == set(WHEELS) else None,
            }
            for g in u.indistinguishable
        ]
        out["untested"] = list(u.untested)
    out["verdict"] = robot.verdict.to_dict()
    if robot.lateral_drift is not None:
        out["lateral_drift"] = robot.lateral_drift.to_dict()
    return out


def feature_lines(r: dict, definition) -> list[str]:
    """A robot's features and their intervals, in words.

    Where Eq. 4's estimate and the posterior disagree
    (:func:`~mirl.learning.verdicts.estimate_disagrees`), the posterior's medians are given as
    the answer and Eq. 4's labelled as the paper's estimate — one answer per question
    (docs/design.md, "Fault verdicts").

    Parameters
    ----------
    r : dict
        The robot's record in :func:`learn_record`'s ``robots``.
    definition : DamageDefinition
        What "damaged" means (:class:`~mirl.world.faults.DamageDefinition`).

    Returns
    -------
    list of str
        The ``features`` line, and the ``95 % interval`` and ``Eq. 4`` lines where the
        record has intervals and the estimates disagree.
    """
    from mirl.learning.verdicts import estimate_disagrees

    probs = r["feature_probabilities"]
    spans = r.get("feature_intervals")
    same = _same_value_note(r)
    if not spans:
        return [f"features      {_values(probs, '=', 3)}{same}"]
    interval = "  ".join(f"{k} {lo:.2f}–{hi:.2f}" for k, (lo, hi) in spans.items())
    medians = r.get("feature_medians")
    if medians is None or not estimate_disagrees(probs, spans, medians, definition):
        return [f"features      {_values(probs, '=', 3)}{same}", f"95 % interval {interval}"]
    return [
        f"features      {_values(r['feature_medians'], ' ', 2)}  (the posterior's medians){same}",
        f"95 % interval {interval}",
        f"Eq. 4         {_values(probs, '=', 3)}  (the paper's estimate, from the step outcomes "
        "alone; L plans with it)",
    ]


def _values(values: dict, sep: str, digits: int) -> str:
    return "  ".join(f"{k}{sep}{v:.{digits}f}" for k, v in values.items())


def _same_value_note(r: dict) -> str:
    """The parts the steps cannot tell apart, and those they cannot test, as a note for the
    features line."""
    from mirl.learning.verdicts import untested_words

    notes = []
    for group in r.get("indistinguishable", []):
        names = " and ".join(group["features"])
        side = "; the drift tells the side" if group["told_apart_by"] == "drift" else ""
        notes.append(f"{names}: the steps cannot tell them apart{side}")
    if r.get("untested"):
        notes.append(untested_words(r["untested"]))
    return f"  ({'; '.join(notes)})" if notes else ""


def motion_line(r: dict) -> str | None:
    """The motion models' weights and the one L plans with, in words.

    Parameters
    ----------
    r : dict
        The robot's record in :func:`learn_record`'s ``robots``.

    Returns
    -------
    str or None
        The ``motion`` line; None when the record has no motion models.
    """
    from mirl.learning.motion_models import motion_sentence

    weights = r.get("motion_models")
    if not weights:
        return None
    return f"motion        {motion_sentence(weights, r.get('motion_model', ''))}"


def record_lines(verdict: dict) -> list[str]:
    """What the verdict left out of the record, and what would make a misfit record fit."""
    from mirl.cli.flags import in_flags

    fit = verdict.get("fit")
    if not fit:
        return []
    lines = []
    left = ", ".join(f"{n} {why}" for why, n in fit.get("left_out", {}).items())
    if left:
        lines.append(f"left out      {left}")
    if fit.get("fix"):
        lines.append(f"to fit        {in_flags(fit['fix'])}")
    return lines


def _observed_line(m: dict) -> str:
    """A robot's score against its observed moves (data without a truth)."""
    if not m["moves"]:
        return "behaviour     no observed moves (never seen at two consecutive steps)"
    return (
        f"behaviour     {m['followed']} of {m['moves']} observed moves follow the learned "
        f"policy ({m['share']:.3f}; against the observed steps only, the data has no truth); "
        f"{m['unexplained']} explained by no action"
    )


def _pair_labels(result, scenario) -> dict:
    """Teams of three or more: the equilibrium learned for each pair L saw meet."""
    if len(scenario.robots) <= 2:
        return {}
    names = scenario.robot_names
    return {
        "pair_equilibria": {
            f"{names[i]}/{names[j]}": e.label() for (i, j), e in result.pair_equilibria.items()
        }
    }


def print_learn(out: dict, result, scenario) -> None:
    """Print the text form of ``mirl learn``'s result to standard output.

    Parameters
    ----------
    out : dict
        The result's record (:func:`learn_record`).
    result : LearnResult
        The result itself (its method, message, label changes, iterations and timings).
    scenario : Scenario
        The scenario it was learned on.
    """
    robots = out["robots"]
    view = f"observability {out['observability']:g}"
    if out.get("visible") == "observed":  # learned under the cells seen, not the degree's
        view = (
            "L's view: the cells the robots were observed on, "
            f"{out['observability']:.3g} of the hallway"
        )
    print(
        f"{result.method} on {scenario.name}: {out['observations']} ({out['steps']} steps, "
        f"{view})"
    )
    for name, r in robots.items():
        print(f"robot {name}")
        print("  weights       " + "  ".join(f"{k}={v:.3f}" for k, v in r["weights"].items()))
        probs = r["feature_probabilities"]
        if not probs:
            print(f"  features      {result.message}")
        for line in feature_lines(r, scenario.faults) if probs else []:
            print(f"  {line}")
        motion = motion_line(r)
        if motion is not None:
            print(f"  {motion}")
        if "lateral_drift" in r:
            print("  " + drift_line(r["lateral_drift"]))
        if "verdict" in r:
            print(f"  verdict       {verdict_sentence(name, r['verdict'])}")
            for line in record_lines(r["verdict"]):
                print(f"  {line}")
        if r["behavior_accuracy"] is not None:
            print(f"  behaviour accuracy {r['behavior_accuracy']:.3f} (vs the scenario's truth)")
        if "observed_moves" in r:
            print("  " + _observed_line(r["observed_moves"]))
    weights = ", ".join(
        f"{c['label']} {c['weight']:.2f}"
        for c in out["equilibrium"]["candidates"]
        if c["weight"] is not None
    )
    print(
        f"equilibrium   {out['equilibrium']['label']}"
        + (f" (weights: {weights})" if weights else "")
    )
    if out.get("pair_equilibria"):  # a team: each pair L weighed on its own
        pairs = ", ".join(f"{p} {label}" for p, label in out["pair_equilibria"].items())
        print(f"pairs         {pairs} (other pairs: the equilibrium above)")
    elif "pair_equilibria" in out:  # a team none of whose pairs L saw meet
        print("pairs         none seen meeting (every pair: the equilibrium above)")
    changes = ", ".join(map(str, result.label_changes))
    print(
        f"iterations    {result.iterations}"
        + (f" (labels changed: {changes}; {result.message})" if changes else "")
    )
    print("timings       " + ", ".join(f"{k} {v:.2f} s" for k, v in result.timings.items()))
