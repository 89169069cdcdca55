"""Running an experiment grid: in parallel (joblib processes, or a Dask cluster through joblib's
dask backend), every finished run committed to ``DIR/results.sqlite`` as it arrives.

The parent process alone writes — one transaction per run, WAL journal, primary key
(condition_key, run) — so killing the sweep at any moment loses only the runs in flight, and
``resume=True`` runs exactly what is missing.
"""

from __future__ import annotations

import sys
import time
import traceback
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import ExitStack
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from mirl._blas import one_blas_thread
from mirl._validation import OptionError
from mirl.experiments.conditions import (
    OUTCOMES,
    Condition,
    Experiment,
    RunFunction,
    StoreError,
    _maybe_float,
    code_version,
    get_experiment,
    in_world,
    run_seed,
    with_em_init,
    with_protocol,
)
from mirl.experiments.options import PAPER_GO_RULE, SweepOptions
from mirl.experiments.store import RunRecord, open_store
from mirl.learning.options import EM_INITS
from mirl.worlds import get_world

__all__ = ["Summary", "run_experiment", "conditions_of"]

# ---------------------------------------------------------------------------------------------
# Execution


def _execute(fn: RunFunction, experiment: str, cond: Condition, run: int, seed: int) -> RunRecord:
    """Worker side: one run, never raising — a failing run becomes an ``error`` record so one
    bad condition does not take the sweep down (resume retries error rows)."""
    one_blas_thread()  # workers of any backend (loky, Dask, in-process) use one BLAS thread
    start = time.perf_counter()
    try:
        res = dict(fn(cond, seed))
        error = ""
    except Exception as exc:  # noqa: BLE001 — recorded, reported, retried on resume
        tb = traceback.format_exception_only(type(exc), exc)[-1].strip()
        res, error = {"outcome": "error"}, tb
    elapsed = time.perf_counter() - start
    outcome = str(res.pop("outcome"))
    if not error and outcome not in OUTCOMES:
        outcome, error = "error", f"run function returned outcome '{outcome}'"
    return RunRecord(
        experiment=experiment,
        condition_key=cond.key,
        run=run,
        seed=seed,
        outcome=outcome,
        go_time=_maybe_float(res.pop("go_time", None)),
        behavior_accuracy=_maybe_float(res.pop("behavior_accuracy", None)),
        feature_probabilities=dict(res.pop("feature_probabilities", None) or {}),
        timings=dict(res.pop("timings", None) or {}),
        metrics=res,
        error=error,
        elapsed=elapsed,
        version=run_version(cond),
    )


def run_version(cond: Condition) -> str:
    """What computed a run: mirl's fingerprint, and for the physics world MuJoCo's version too
    (its trajectories differ between MuJoCo releases), so the report flags a store that mixes
    them."""
    world_version = get_world(cond.world).load().version()
    return code_version() + (f"+{world_version}" if world_version else "")


def split_version(version: str) -> tuple[str, str]:
    """A row's version (:func:`run_version`) as mirl's fingerprint and its world's part.

    Parameters
    ----------
    version : str
        ``"0.2.0+src.0123456789"`` or ``"0.2.0+src.0123456789+mujoco.3.17.0"``.

    Returns
    -------
    tuple of str
        The fingerprint (:func:`~mirl.experiments.conditions.code_version`'s form) and what
        the world adds ("" for nothing, or a version not of that form).
    """
    head, sep, tail = version.partition("+src.")
    if not sep or len(tail) < _HASH_CHARS:
        return version, ""
    return head + sep + tail[:_HASH_CHARS], tail[_HASH_CHARS:].removeprefix("+")


_HASH_CHARS = 10  # code_version's hash


@dataclass
class Summary:
    """What one invocation of a sweep did; :meth:`line` says it in one line.

    Parameters
    ----------
    experiment : str
        The experiment's name.
    out_dir : Path
        Its results directory.
    planned : int
        The (condition, run) pairs of the grid: conditions × runs.
    already_done : int
        Those finished before this invocation.
    finished : int
        Those finished in this invocation.
    wall_seconds : float
        This invocation's wall time.
    workers : int
        Its worker processes.
    outcomes : dict of str to int, default {}
        This invocation's runs per outcome.
    """

    experiment: str
    out_dir: Path
    planned: int  # conditions × runs
    already_done: int  # finished before this session
    finished: int  # finished in this session
    wall_seconds: float
    workers: int
    outcomes: dict[str, int] = field(default_factory=dict)

    @property
    def runs_per_minute(self) -> float:
        """This invocation's throughput (0 if it took no time)."""
        return 60.0 * self.finished / self.wall_seconds if self.wall_seconds > 0 else 0.0

    def line(self) -> str:
        """The summary as ``mirl experiment`` prints it.

        Returns
        -------
        str
            Runs, wall time, workers, throughput, progress and outcomes, in one line.
        """
        counts = ", ".join(f"{k} {v}" for k, v in sorted(self.outcomes.items()))
        return (
            f"{self.experiment}: {self.finished} runs in {self.wall_seconds / 60:.1f} min on "
            f"{self.workers} worker{'s' * (self.workers != 1)} "
            f"({self.runs_per_minute:.1f} runs/min); "
            f"{self.already_done + self.finished}/{self.planned} done; this session: {counts}"
        )


def run_experiment(
    experiment: Experiment | str,
    out_dir: str | Path,
    options: SweepOptions | Mapping[str, Any] | None = None,
    *,
    log: Callable[[str], None] | None = None,
) -> Summary:
    """Run every pending (condition, run) of ``experiment``, storing each result as it arrives
    in ``out_dir/results.sqlite``; export ``out_dir/results.csv`` at the end.

    .. versionchanged:: 0.2.0
       The settings are one ``options`` argument, with the command line's defaults: one worker
       per CPU and mirl's protocol on the runs of L (``go_rule="value", relearn=False`` keeps
       the conditions' own, the paper's).

    Parameters
    ----------
    experiment : Experiment or str
        An experiment or its name in :data:`~mirl.experiments.conditions.EXPERIMENTS`.
    out_dir : str or Path
        The results directory (created if missing).
    options : SweepOptions or mapping, optional
        How to run it (:class:`~mirl.experiments.options.SweepOptions`: runs, workers,
        resume, Dask, the base seed, progress, and the world, go rule, re-learning and DBN-EM
        initialisation every condition takes), or a mapping of its option names to values; by
        default ``mirl experiment``'s. Without ``resume`` an existing non-empty database is
        refused (StoreError) rather than silently mixed; with it, finished runs are skipped,
        ``error`` runs retried, and a larger ``runs`` extends the sweep.
    log : callable, optional
        Receives the sweep's lines (default: stderr).

    Returns
    -------
    Summary
        What ran, how fast, and the outcomes of this session.
    """
    opts = SweepOptions.of(options)
    exp = get_experiment(experiment) if isinstance(experiment, str) else experiment
    exp = with_em_init(exp, opts.em_init)
    exp = with_protocol(exp, opts.go_rule, opts.relearn)
    exp = in_world(exp, opts.world)
    runs = exp.default_runs if opts.runs is None else opts.runs
    workers, resume, dask_scheduler = opts.n_workers, opts.resume, opts.dask_scheduler
    base_seed, progress, progress_every = opts.base_seed, opts.progress, opts.progress_every
    out = Path(out_dir)
    emit = log or (lambda msg: print(msg, file=sys.stderr))
    with ExitStack() as stack:
        # the cluster first: an address no scheduler answers leaves no store behind
        client = stack.enter_context(_dask_client(dask_scheduler)) if dask_scheduler else None
        out.mkdir(parents=True, exist_ok=True)
        store = open_store(out / "results.sqlite", exp.name, base_seed, resume=resume)
        stack.callback(store.close)
        _check_same_grid(exp, store.finished_keys(), out / "results.sqlite")
        retried = store.delete_errors()
        if retried:
            emit(f"{exp.name}: retrying {retried} runs that failed before")
        done = store.finished_keys()
        tasks = [
            (cond, i, run_seed(base_seed, i))
            for i in range(runs)  # run-major: a partial sweep covers every condition evenly
            for cond in exp.conditions
            if (cond.key, i) not in done
        ]
        planned = runs * len(exp.conditions)
        already = planned - len(tasks)
        # what the sweep was asked for, so that a report of an interrupted one says it is short
        asked = max(planned, int(store.meta().get("planned_runs", 0)))
        store.set_meta(planned_runs=str(asked))
        n_workers = workers if client is None else _dask_threads(client)
        summary = Summary(exp.name, out, planned, already, 0, 0.0, n_workers)
        emit(
            f"{exp.name}: {len(exp.conditions)} conditions × {runs} runs; {already} done, "
            f"{len(tasks)} to run on {n_workers} worker{'s' * (n_workers != 1)}"
            + (f" via dask at {dask_scheduler}" if dask_scheduler else "")
        )
        session = store.begin_session(n_workers, "dask" if dask_scheduler else "joblib")
        start = time.perf_counter()
        every = progress_every or max(1, len(tasks) // 20)
        with _ProgressLog(out / "progress.log", len(tasks), exp.name, progress, every) as bar:
            for rec in _results(exp, tasks, workers, dask_scheduler):
                summary.finished += 1
                # committed before anything else happens
                store.add(rec, session, summary.finished, time.perf_counter() - start)
                summary.outcomes[rec.outcome] = summary.outcomes.get(rec.outcome, 0) + 1
                bar.update(rec)
        summary.wall_seconds = time.perf_counter() - start
        order = {c.key: k for k, c in enumerate(exp.conditions)}
        store.export_csv(out / "results.csv", order)
        emit(summary.line())
        if summary.outcomes.get("error"):
            emit(f"{exp.name}: {summary.outcomes['error']} runs failed; see the 'error' column")
        return summary


# what a sweep's options set on every condition; the other fields are the experiment's grid
_PROTOCOL_FIELDS = ("world", "go_rule", "relearn", "em_init")


def _check_same_grid(exp: Experiment, stored: set[tuple[str, int]], db: Path) -> None:
    """Refuse a resumed sweep whose conditions are not the stored runs': under another world,
    go rule, re-learning or DBN-EM start, its runs would be stored beside them under new keys
    and reported in the same tables as the same methods, none of them skipped."""
    keys = {c.key for c in exp.conditions}
    other = sorted({key for key, _ in stored} - keys)
    if not other:
        return
    was = Condition.from_key(other[0])
    grid = {k: v for k, v in asdict(was).items() if k not in _PROTOCOL_FIELDS}
    same = [c for c in exp.conditions if {k: getattr(c, k) for k in grid} == grid]
    if not same:
        raise StoreError(f"{db} holds runs of conditions {exp.name} does not have ({other[0]})")
    now = same[0]
    diff = [f for f in _PROTOCOL_FIELDS if getattr(was, f) != getattr(now, f)]
    unset = {"go_rule": PAPER_GO_RULE, "em_init": EM_INITS.names[0]}  # None: the default

    def values(c: Condition) -> str:
        return ", ".join(f"{f}={getattr(c, f) or unset.get(f, getattr(c, f))!r}" for f in diff)

    shown, asked = values(was), values(now)
    flags = ", ".join(f"`{f}`" for f in diff)
    raise StoreError(
        f"{db} holds runs of {exp.name} with {shown}, not {asked} as asked ({flags}); resume it "
        "as it was started, or choose another directory (`out`)"
    )


def _results(
    exp: Experiment, tasks: list[tuple[Condition, int, int]], workers: int, scheduler: str | None
) -> Iterator[RunRecord]:
    """Results in completion order, so each is stored as soon as it exists."""
    if not tasks:
        return
    import joblib

    calls = (joblib.delayed(_execute)(exp.run_function, exp.name, c, i, s) for c, i, s in tasks)
    if scheduler is None:
        # batch_size=1: runs last seconds, so per-task overhead is nothing next to losing a
        # whole batch of finished-but-unreturned runs on a kill
        par = joblib.Parallel(
            n_jobs=workers, return_as="generator_unordered", batch_size=1, pre_dispatch="2*n_jobs"
        )
        yield from par(calls)
        return
    # the dask backend runs on the client opened by run_experiment
    with joblib.parallel_config(backend="dask"):
        par = joblib.Parallel(
            n_jobs=-1, return_as="generator_unordered", batch_size=1, pre_dispatch="all"
        )
        yield from par(calls)


def _dask_client(address: str):
    from distributed import Client

    try:
        return Client(address, timeout="30s")
    except OSError as exc:  # no scheduler there: say which option named it
        problem = f"{address}: no Dask scheduler answered ({exc})"
        raise OptionError("dask_scheduler", problem) from None


def _dask_threads(client: Any) -> int:
    return sum(client.nthreads().values()) or 1


class _ProgressLog:
    """tqdm bar with ETA on a terminal; otherwise a line on stderr every ``every`` runs; and
    always in ``progress.log`` one line per run with the count, the run and the ETA, so a
    detached sweep can be followed with tail."""

    def __init__(self, path: Path, total: int, name: str, show: bool, every: int = 1) -> None:
        from tqdm import tqdm

        self.total, self.name, self.start, self.n = total, name, time.perf_counter(), 0
        self.file = path.open("a", encoding="utf-8")
        tty = show and sys.stderr.isatty()
        self.bar = tqdm(
            total=total, desc=name, unit="run", file=sys.stderr, disable=not tty, smoothing=0.05
        )
        self.echo = show and not tty
        self.every = every

    def update(self, rec: RunRecord) -> None:
        self.n += 1
        self.bar.update(1)
        elapsed = time.perf_counter() - self.start
        eta = elapsed / self.n * (self.total - self.n)
        cond = Condition.from_key(rec.condition_key)
        line = (
            f"{time.strftime('%H:%M:%S')} {self.name} {self.n}/{self.total} {cond.label} "
            f"d={cond.observability:g} steps={cond.obs_steps} {cond.scenario} run {rec.run}: "
            f"{rec.outcome} in {rec.elapsed:.1f}s; ETA {_hms(eta)}"
        )
        self.file.write(line + "\n")
        self.file.flush()
        if self.echo and (self.n % self.every == 0 or self.n == self.total):
            print(line, file=sys.stderr, flush=True)

    def __enter__(self) -> _ProgressLog:
        return self

    def __exit__(self, *exc: object) -> None:
        self.bar.close()
        self.file.close()


def _hms(seconds: float) -> str:
    s = int(round(seconds))
    return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"


def conditions_of(rows: Iterable[Mapping[str, Any]]) -> list[Condition]:
    """Distinct conditions of stored rows, in first-seen order.

    Parameters
    ----------
    rows : iterable of mapping
        Stored runs (:meth:`~mirl.experiments.store.ResultStore.rows`), each with its
        ``condition_key``.

    Returns
    -------
    list of Condition
        One per distinct key.
    """
    seen: dict[str, Condition] = {}
    for r in rows:
        seen.setdefault(r["condition_key"], Condition.from_key(r["condition_key"]))
    return list(seen.values())
