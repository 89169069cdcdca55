"""What ``mirl learn`` reports: the record of a learned result (its ``--json`` output) and the
text form printed without ``--json``."""

from __future__ import annotations

__all__ = ["drift_line", "learn_record", "print_learn", "verdict_sentence"]


def verdict_sentence(robot: str, record: dict) -> str:
    """A verdict's JSON record (:meth:`~mirl.learning.verdicts.Verdict.to_dict`) in words."""
    from mirl.learning.verdicts import Verdict

    verdict = Verdict(record["part"], record["confidence"], tuple(record["candidates"]))
    return verdict.sentence(robot)


def learn_record(
    result, scenario, observations: str, steps: int, degree: float, agreement=None
) -> dict:
    """The JSON-ready record of ``result`` (a :class:`~mirl.learning.results.LearnResult`)
    learned on ``scenario`` from ``observations`` (``steps`` long, at observability ``degree``).

    ``agreement`` (robot name -> :class:`~mirl.learning.results.ObservedAgreement`) is given
    when the data has no truth: each robot's record then scores its policy against the observed
    moves only (``observed_moves``) and has no ``behavior_accuracy`` against the scenario.
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


def drift_line(record: dict) -> str:
    """A lateral drift's JSON record (:meth:`~mirl.learning.verdicts.LateralDrift.to_dict`)
    in words."""
    from mirl.learning.verdicts import LateralDrift

    drift = LateralDrift(record["mean"], record["se"], record["steps"])
    return f"drift         {drift.sentence()} (a robot veers towards a weak wheel)"


def _uncertainty(robot) -> dict:
    """``feature_intervals`` (95 %, [lo, hi]) and ``verdict`` of a model that has them."""
    if robot.verdict is None:
        return {}
    return {
        "feature_intervals": {
            f: [round(float(lo), 4), round(float(hi), 4)]
            for f, (lo, hi) in robot.feature_intervals.items()
        },
        "verdict": robot.verdict.to_dict(),
        **(
            {"lateral_drift": robot.lateral_drift.to_dict()}
            if robot.lateral_drift is not None
            else {}
        ),
    }


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


def print_learn(out: dict, result, scenario_name: str) -> None:
    """The text form of ``mirl learn``'s result."""
    from mirl.learning.verdicts import estimate_outside_interval, outside_interval_note

    robots = out["robots"]
    print(
        f"{result.method} on {scenario_name}: {out['observations']} ({out['steps']} steps, "
        f"observability {out['observability']:g})"
    )
    for name, r in robots.items():
        print(f"robot {name}")
        print("  weights       " + "  ".join(f"{k}={v:.3f}" for k, v in r["weights"].items()))
        probs = r["feature_probabilities"]
        line = "  ".join(f"{k}={v:.3f}" for k, v in probs.items()) if probs else result.message
        print(f"  features      {line}")
        if "feature_intervals" in r:
            spans = "  ".join(
                f"{k} {lo:.2f}–{hi:.2f}" for k, (lo, hi) in r["feature_intervals"].items()
            )
            print(f"  95 % interval {spans}")
            if estimate_outside_interval(probs, r["feature_intervals"]):
                print("  " + outside_interval_note("lateral_drift" in r))
            if "lateral_drift" in r:
                print("  " + drift_line(r["lateral_drift"]))
            print(f"  verdict       {verdict_sentence(name, r['verdict'])}")
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
    changes = ", ".join(map(str, result.label_changes))
    print(
        f"iterations    {result.iterations}"
        + (f" (labels changed: {changes}; {result.message})" if changes else "")
    )
    print("timings       " + ", ".join(f"{k} {v:.2f} s" for k, v in result.timings.items()))
