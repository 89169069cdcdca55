"""The SQLite store of an experiment: one row per finished run, one transaction per run (so an
interrupted sweep loses nothing and a resumed one duplicates nothing), sessions for throughput."""

from __future__ import annotations

import csv
import json
import os
import sqlite3
import sys
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from mirl._version import package_version
from mirl.experiments.conditions import (
    OUTCOMES,
    Condition,
    StoreError,
)

__all__ = ["RunRecord", "ResultStore", "check_store", "open_store", "load_results"]

# ---------------------------------------------------------------------------------------------
# The SQLite store


@dataclass(frozen=True)
class RunRecord:
    """One finished run as stored: one row of the ``runs`` table.

    Parameters
    ----------
    experiment : str
        The experiment's name (a row of :data:`~mirl.experiments.conditions.EXPERIMENTS`).
    condition_key : str
        The run's condition, as :attr:`Condition.key <mirl.experiments.conditions.Condition.key>`
        writes it.
    run : int
        The run's index within its condition.
    seed : int
        The run's seed.
    outcome : str
        How it ended: one of :data:`~mirl.experiments.conditions.OUTCOMES`, or ``"error"``
        for a run that raised (retried on resume).
    go_time : float or None
        The step L went at (None: it never went).
    behavior_accuracy : float or None
        The learned policies' behaviour accuracy, the mean over the patrollers.
    feature_probabilities : dict of str to dict of str to float
        Per robot, per feature, the learned success probability.
    timings : dict of str to float
        Wall seconds per phase.
    metrics : dict
        The experiment's further numbers (its run function's).
    error : str
        The error's message, for an ``"error"`` run (else empty).
    elapsed : float
        The run's wall seconds.
    version : str
        What the result depends on: mirl's version and code, and the world's.
    """

    experiment: str
    condition_key: str
    run: int
    seed: int
    outcome: str  # success / detected / timeout, or error (retried on resume)
    go_time: float | None
    behavior_accuracy: float | None
    feature_probabilities: dict[str, dict[str, float]]
    timings: dict[str, float]
    metrics: dict[str, Any]
    error: str
    elapsed: float
    version: str


_SCHEMA = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE IF NOT EXISTS runs (
    condition_key TEXT NOT NULL,
    run INTEGER NOT NULL,
    seed INTEGER NOT NULL,
    experiment TEXT NOT NULL,
    method TEXT NOT NULL,
    scenario TEXT NOT NULL,
    observability REAL NOT NULL,
    obs_steps INTEGER NOT NULL,
    p REAL,
    outcome TEXT NOT NULL,
    go_time REAL,
    behavior_accuracy REAL,
    metrics TEXT NOT NULL,
    feature_probabilities TEXT NOT NULL,
    timings TEXT NOT NULL,
    error TEXT NOT NULL,
    elapsed REAL NOT NULL,
    version TEXT NOT NULL,
    finished_at TEXT NOT NULL,
    PRIMARY KEY (condition_key, run)
);
CREATE TABLE IF NOT EXISTS sessions (
    id INTEGER PRIMARY KEY AUTOINCREMENT,
    started_at TEXT NOT NULL,
    backend TEXT NOT NULL,
    workers INTEGER NOT NULL,
    finished INTEGER NOT NULL DEFAULT 0,
    seconds REAL NOT NULL DEFAULT 0,
    version TEXT NOT NULL
);
"""


def _writer_lock(path: Path) -> IO[bytes]:
    """An exclusive lock on ``path``'s sidecar ``<name>.lock``, held until the handle closes.

    Two sweeps writing one store ran every run twice, and one started with another base seed
    before the first had committed a run set the store's seed while the first's rows stayed.
    The operating system releases the lock when its process ends, however it ends, so a killed
    sweep never blocks its resume.

    Parameters
    ----------
    path : Path
        The database file.

    Returns
    -------
    file object
        The open lock file; closing it releases the lock.

    Raises
    ------
    StoreError
        Another process holds the lock.
    """
    handle = open(path.with_name(path.name + ".lock"), "a+b")  # held open: it is the lock
    try:
        if sys.platform == "win32":
            import msvcrt

            msvcrt.locking(handle.fileno(), msvcrt.LK_NBLCK, 1)
        else:
            import fcntl

            fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        handle.close()
        raise StoreError(
            f"{path}: another sweep is writing to it; wait until it ends, or choose another "
            "directory (`out`)"
        ) from None
    return handle


class ResultStore:
    """``results.sqlite``: ``runs`` (one row per finished (condition, run); JSON columns for
    metrics, feature probabilities and timings), ``meta`` (experiment, base seed) and
    ``sessions`` (workers, runs and wall time of each invocation, for throughput).

    Only the parent process writes, and only one process at a time: a writer holds a lock on
    ``<path>.lock`` until :meth:`close`. Each run is one ``BEGIN IMMEDIATE … COMMIT`` with
    ``INSERT OR IGNORE`` on the primary key, so a kill leaves the database consistent and a
    re-delivered result can never duplicate a row.

    Parameters
    ----------
    path : str or Path
        The database file (created with its tables unless ``read_only``).
    read_only : bool, default False
        Open it so that nothing, not even SQLite's journal files, changes it (``mirl
        report``).

    Raises
    ------
    StoreError
        Another process writes to it (not with ``read_only``).
    """

    def __init__(self, path: str | Path, *, read_only: bool = False) -> None:
        self.path = Path(path)
        self._lock: IO[bytes] | None = None
        if read_only:  # `mirl report`: reading results never changes them
            self.con = _read_only(self.path)
            return
        self._lock = _writer_lock(self.path)
        try:
            self.con = sqlite3.connect(self.path, isolation_level=None, timeout=60)
        except BaseException:
            self._lock.close()
            raise
        self.con.execute("PRAGMA journal_mode=WAL")
        # WAL + NORMAL: a committed run survives a killed process (only an OS crash could
        # lose the last commits), at a fraction of FULL's fsync cost
        self.con.execute("PRAGMA synchronous=NORMAL")
        self.con.executescript(_SCHEMA)

    @contextmanager
    def _tx(self) -> Iterator[sqlite3.Connection]:
        self.con.execute("BEGIN IMMEDIATE")
        try:
            yield self.con
        except BaseException:
            self.con.execute("ROLLBACK")
            raise
        self.con.execute("COMMIT")

    def meta(self) -> dict[str, str]:
        """The ``meta`` table: what the sweep was started with.

        Returns
        -------
        dict of str to str
            ``experiment`` and ``base_seed`` (empty for a new store).
        """
        return dict(self.con.execute("SELECT key, value FROM meta"))

    def set_meta(self, **values: str) -> None:
        """Write entries of the ``meta`` table, in one transaction.

        Parameters
        ----------
        **values : str
            The entries, by key (an existing key is replaced).
        """
        with self._tx() as con:
            con.executemany("INSERT OR REPLACE INTO meta VALUES (?, ?)", values.items())

    def count(self) -> int:
        """The runs stored.

        Returns
        -------
        int
            Rows of the ``runs`` table, errors included.
        """
        return int(self.con.execute("SELECT COUNT(*) FROM runs").fetchone()[0])

    def finished_keys(self) -> set[tuple[str, int]]:
        """The (condition, run) pairs stored, which a resumed sweep skips.

        Returns
        -------
        set of (str, int)
            (condition key, run index) of every stored run.
        """
        return set(self.con.execute("SELECT condition_key, run FROM runs"))

    def delete_errors(self) -> int:
        """Remove the runs that raised, so that a resumed sweep runs them again.

        Returns
        -------
        int
            The runs removed.
        """
        with self._tx() as con:
            return con.execute("DELETE FROM runs WHERE outcome = 'error'").rowcount

    def begin_session(self, workers: int, backend: str) -> int:
        """Record the start of a sweep's invocation.

        Parameters
        ----------
        workers : int
            Its worker processes.
        backend : str
            Where it runs: ``"joblib"`` (this machine) or ``"dask"`` (a cluster).

        Returns
        -------
        int
            The session's id, for :meth:`add`.
        """
        with self._tx() as con:
            cur = con.execute(
                "INSERT INTO sessions (started_at, backend, workers, version) VALUES (?,?,?,?)",
                (_now(), backend, workers, package_version()),
            )
            return int(cur.lastrowid or 0)

    def add(self, rec: RunRecord, session: int, finished: int, seconds: float) -> None:
        """Store one finished run and its session's progress, in one transaction (a run
        stored already is left as it is).

        Parameters
        ----------
        rec : RunRecord
            The run.
        session : int
            The session's id (:meth:`begin_session`).
        finished : int
            Runs the session has finished, this one included.
        seconds : float
            The session's wall seconds so far.
        """
        c = Condition.from_key(rec.condition_key)
        row = (
            rec.condition_key, rec.run, rec.seed, rec.experiment, c.method, c.scenario,
            c.observability, c.obs_steps, c.p, rec.outcome, rec.go_time, rec.behavior_accuracy,
            json.dumps(rec.metrics, sort_keys=True), json.dumps(rec.feature_probabilities),
            json.dumps(rec.timings), rec.error, rec.elapsed, rec.version, _now(),
        )  # fmt: skip
        with self._tx() as con:
            con.execute(f"INSERT OR IGNORE INTO runs VALUES ({','.join('?' * len(row))})", row)
            con.execute(
                "UPDATE sessions SET finished = ?, seconds = ? WHERE id = ?",
                (finished, seconds, session),
            )

    def sessions(self) -> list[dict[str, Any]]:
        """Every invocation of the sweep, in order.

        Returns
        -------
        list of dict
            Per session its ``id``, ``started_at``, ``backend``, ``workers``, ``finished``,
            ``seconds`` and ``version``.
        """
        cur = self.con.execute("SELECT * FROM sessions ORDER BY id")
        names = [d[0] for d in cur.description]
        return [dict(zip(names, r, strict=True)) for r in cur]

    def rows(self) -> list[dict[str, Any]]:
        """Every run as a flat dict: fixed columns, then ``metric.*``-free metric names,
        ``fp.<robot>.<feature>`` and ``time.<phase>``.

        Returns
        -------
        list of dict
            One per run, ordered by condition and run: the fixed columns, the metrics, the
            feature probabilities, the timings, then ``elapsed``, ``error``, ``version``,
            ``finished_at`` and ``condition_key``.
        """
        cur = self.con.execute("SELECT * FROM runs ORDER BY condition_key, run")
        names = [d[0] for d in cur.description]
        out = []
        for values in cur:
            r = dict(zip(names, values, strict=True))
            flat = {k: r[k] for k in _FIXED_COLUMNS}
            flat.update(json.loads(r["metrics"]))
            for robot, fp in json.loads(r["feature_probabilities"]).items():
                flat.update({f"fp.{robot}.{f}": v for f, v in fp.items()})
            flat.update({f"time.{k}": v for k, v in json.loads(r["timings"]).items()})
            flat.update({k: r[k] for k in _TRAILING_COLUMNS})
            out.append(flat)
        return out

    def export_csv(self, path: str | Path, order: Mapping[str, int] | None = None) -> int:
        """Write every run to ``path`` (atomically: a kill never leaves half a CSV).

        Parameters
        ----------
        path : str or Path
            The CSV file (replaced).
        order : mapping of str to int, optional
            The conditions' order, by key (the experiment's); by key and run if None.

        Returns
        -------
        int
            The runs written.
        """
        rows = self.rows()
        if order:
            rows.sort(key=lambda r: (order.get(r["condition_key"], len(order)), r["run"]))
        columns: dict[str, None] = {}
        for r in rows:
            columns.update(dict.fromkeys(r))
        tmp = Path(f"{path}.tmp")
        with tmp.open("w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, fieldnames=list(columns), restval="", lineterminator="\n")
            w.writeheader()
            w.writerows(rows)
        os.replace(tmp, path)
        return len(rows)

    def close(self) -> None:
        """Close the connection, and release the writer's lock."""
        self.con.close()
        if self._lock is not None:
            self._lock.close()


_FIXED_COLUMNS = (
    "experiment", "method", "scenario", "observability", "obs_steps", "p", "run", "seed",
    "outcome", "go_time", "behavior_accuracy",
)  # fmt: skip
_TRAILING_COLUMNS = ("elapsed", "error", "version", "finished_at", "condition_key")


def _now() -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S")


_SQLITE_MAGIC = b"SQLite format 3\x00"


def _read_only(path: Path) -> sqlite3.Connection:
    """A connection that cannot change ``path``; ``immutable`` (no -wal/-shm files created)
    unless a write-ahead log already holds committed runs that must be read too."""
    mode = "mode=ro" if Path(f"{path}-wal").exists() else "immutable=1"
    return sqlite3.connect(f"{path.resolve().as_uri()}?{mode}", uri=True)


def check_store(path: str | Path) -> None:
    """Refuse (StoreError, one line) an existing ``results.sqlite`` that is empty, not SQLite,
    truncated, corrupt or not mirl's — reading it only, so the file stays byte for byte as it
    was (connecting read-write would turn an empty file into a database).

    Parameters
    ----------
    path : str or Path
        The database file (nothing is checked if it does not exist).

    Raises
    ------
    StoreError
        If it is not a file, empty, not SQLite, corrupt or without mirl's tables.
    """
    p = Path(path)
    if not p.exists():
        return
    if not p.is_file():
        raise StoreError(f"{p}: not a file")
    with p.open("rb") as fh:
        head = fh.read(100)
    if not head:
        raise StoreError(f"{p}: empty file, not a results database (left as it is)")
    if not head.startswith(_SQLITE_MAGIC):
        raise StoreError(f"{p}: not an SQLite results database (left as it is)")
    try:
        con = _read_only(p)
        try:
            check = con.execute("PRAGMA quick_check").fetchone()[0]
            tables = {r[0] for r in con.execute("SELECT name FROM sqlite_master")}
        finally:
            con.close()
    except sqlite3.DatabaseError as exc:
        raise StoreError(f"{p}: corrupt or truncated database ({exc}; left as it is)") from None
    if check != "ok":
        raise StoreError(f"{p}: corrupt database ({check}; left as it is)")
    if not {"runs", "meta"} <= tables:
        raise StoreError(f"{p}: an SQLite database but not mirl's results (no runs table)")


def open_store(path: str | Path, experiment: str, base_seed: int, *, resume: bool) -> ResultStore:
    """Open (creating) an experiment's store, refusing to mix it with other results: without
    ``resume`` a database that already holds runs is an error, and with it the experiment and
    base seed must be the ones it was started with.

    Parameters
    ----------
    path : str or Path
        The database file.
    experiment : str
        The experiment's name.
    base_seed : int
        The sweep's base seed.
    resume : bool
        Whether runs already stored may be continued.

    Returns
    -------
    ResultStore
        The open store, its ``meta`` set.

    Raises
    ------
    StoreError
        If the file is not a store (:func:`check_store`), holds runs without ``resume``, or
        holds runs of another experiment or base seed.
    """
    check_store(path)
    store = ResultStore(path)
    try:
        n, meta = store.count(), store.meta()
        if n and not resume:
            raise StoreError(
                f"{path} already holds {n} runs of {meta.get('experiment', '?')}; "
                "resume it (`resume`) or choose another directory (`out`)"
            )
        if n and meta.get("experiment") != experiment:
            raise StoreError(f"{path} holds runs of {meta.get('experiment')}, not {experiment}")
        if n and meta.get("base_seed") != str(base_seed):
            raise StoreError(
                f"{path} was started with `base_seed` {meta.get('base_seed')}, not {base_seed}"
            )
        store.set_meta(experiment=experiment, base_seed=str(base_seed))
    except BaseException:
        store.close()
        raise
    return store


def load_results(path: str | Path) -> tuple[dict[str, str], list[dict[str, Any]], list[dict]]:
    """What a sweep stored, read without changing it (``mirl report``).

    Parameters
    ----------
    path : str or Path
        A results directory (its ``results.sqlite``) or the database file.

    Returns
    -------
    meta : dict of str to str
        The ``meta`` table.
    rows : list of dict
        Every run, flat (:meth:`ResultStore.rows`).
    sessions : list of dict
        Every invocation (:meth:`ResultStore.sessions`).

    Raises
    ------
    StoreError
        If there is no database, it is not a store, or it holds runs a sweep cannot have
        written (no experiment or base seed, an unknown outcome).
    """
    p = Path(path)
    db = p / "results.sqlite" if p.is_dir() else p
    if not db.exists():
        raise StoreError(f"{db}: no such results database")
    check_store(db)
    store = ResultStore(db, read_only=True)
    try:
        meta, rows, sessions = store.meta(), store.rows(), store.sessions()
    finally:
        store.close()
    _check_contents(db, meta, rows)
    return meta, rows, sessions


def _check_contents(db: Path, meta: Mapping[str, str], rows: list[dict[str, Any]]) -> None:
    """Refuse runs a sweep cannot have written: without the experiment and base seed that
    ``open_store`` records, or with an outcome no run ends in (they would be counted)."""
    missing = [k for k in ("experiment", "base_seed") if k not in meta]
    if rows and missing:
        raise StoreError(
            f"{db}: {len(rows)} runs but no {' or '.join(missing)} in its meta table (not "
            "written by mirl experiment; left as it is)"
        )
    known = (*OUTCOMES, "error")
    for r in rows:
        if r["outcome"] not in known:
            raise StoreError(
                f"{db}: run {r['run']} of {r['condition_key']} ended in '{r['outcome']}', not "
                f"one of {', '.join(known)} (left as it is)"
            )
