"""Checks of the command line's inputs and outputs that argparse cannot make: output paths
(before any work is done), observation files that parse but say nothing, and the warnings a
user must see. Every refusal is a :class:`UsageError` (one line, exit 2)."""

from __future__ import annotations

import os
import sys
from collections.abc import Mapping
from pathlib import Path

import numpy as np

__all__ = [
    "UsageError",
    "FIGURE_SUFFIXES",
    "MIN_TRIALS",
    "warn",
    "check_output",
    "check_observations",
    "feature_trials",
    "unique_lowest",
]

FIGURE_SUFFIXES = (".png", ".pdf", ".svg")
# a learned probability resting on fewer observed trials than this is flagged as barely informed
MIN_TRIALS = 10


class UsageError(Exception):
    """A problem with the user's input, reported in one line."""


def warn(message: str) -> None:
    print(f"mirl: warning: {message}", file=sys.stderr)


def check_output(path: str | Path, flag: str, suffixes: tuple[str, ...] | None = None) -> Path:
    """Refuse an output file that cannot be written, before the work that would fill it."""
    p = Path(path)
    if suffixes and p.suffix.lower() not in suffixes:
        raise UsageError(f"{flag} {p}: expected a file ending in {', '.join(suffixes)}")
    if p.is_dir():
        raise UsageError(f"{flag} {p}: is a directory")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"{flag} {p}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK) or (p.exists() and not os.access(p, os.W_OK)):
        raise UsageError(f"{flag} {p}: not writable")
    return p


def check_observations(path, obs, domain) -> None:
    """Refuse observations with no rows (nothing to learn from) and warn loudly about observed
    steps that no action explains (a robot jumping between cells L saw it on)."""
    from mirl.learning.transitions import observed_steps, perception_labels

    if len(obs) == 0:
        raise UsageError(f"{path}: no observations (a header and no rows): nothing to learn from")
    for i, name in enumerate(obs.robot_names):
        t, s, s_next = observed_steps(obs.state_series(domain, i))
        bad = np.flatnonzero(perception_labels(domain, s, s_next) < 0)
        if bad.size:
            k = int(bad[0])
            a, b = (tuple(int(x) for x in domain.states[v]) for v in (s[k], s_next[k]))
            warn(
                f"{path}: {bad.size} of robot {name}'s {len(t)} observed steps are explained by "
                f"no action (first: t={int(t[k])} {a} -> {b}); they count as failed actions"
            )


def feature_trials(counts) -> dict[str, int]:
    """Observed trials behind each feature: the trials of every subset that contains it."""
    out: dict[str, int] = {}
    for subset, n in zip(counts.subsets, counts.trials, strict=True):
        for f in subset:
            out[f] = out.get(f, 0) + int(n)
    return out


def unique_lowest(probs: Mapping[str, float], tol: float = 1e-6) -> str | None:
    """The feature with the single lowest probability; None on a tie (no damaged-part guess)."""
    ranked = sorted(probs.items(), key=lambda kv: kv[1])
    if not ranked or (len(ranked) > 1 and ranked[1][1] - ranked[0][1] <= tol):
        return None
    return ranked[0][0]
