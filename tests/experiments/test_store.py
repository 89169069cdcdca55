"""The SQLite store on its own: a run is stored once however often it is delivered, rows read
back flat, a store is never mixed with other results, reading never changes the file, and a
file that is not a store is refused in one line and left as it is."""

from __future__ import annotations

import csv
import sqlite3

import pytest

from mirl.experiments.conditions import Condition, StoreError
from mirl.experiments.store import (
    ResultStore,
    RunRecord,
    check_store,
    load_results,
    open_store,
)

CONDITIONS = (Condition("mirl-t", observability=0.14), Condition("mirl", p=0.9))


def record(condition=CONDITIONS[0], run=0, outcome="success", **kw):
    values = dict(
        experiment="fig4a",
        condition_key=condition.key,
        run=run,
        seed=100 + run,
        outcome=outcome,
        go_time=None if outcome == "error" else 12.0,
        behavior_accuracy=0.9,
        feature_probabilities={"J": {"left_wheel": 0.7, "floor": 1.0}},
        timings={"learn": 1.5},
        metrics={"plan_value": 0.25},
        error="boom" if outcome == "error" else "",
        elapsed=2.0,
        version="0.2.0+src.abc",
    )
    return RunRecord(**{**values, **kw})


@pytest.fixture
def store(tmp_path):
    s = open_store(tmp_path / "results.sqlite", "fig4a", 0, resume=False)
    yield s
    s.close()


def test_rows_read_back_flat_in_condition_and_run_order(store):
    session = store.begin_session(2, "joblib")
    store.add(record(CONDITIONS[1], 1), session, 1, 1.0)
    store.add(record(CONDITIONS[1], 0), session, 2, 2.0)
    store.add(record(CONDITIONS[0], 0), session, 3, 3.0)
    rows = store.rows()
    mirl, mirl_t = CONDITIONS[1].key, CONDITIONS[0].key  # '"' sorts before '-'
    assert [(r["condition_key"], r["run"]) for r in rows] == [(mirl, 0), (mirl, 1), (mirl_t, 0)]
    row = next(r for r in rows if r["condition_key"] == CONDITIONS[1].key)
    assert row["method"] == "mirl" and row["p"] == 0.9 and row["observability"] == 0.14
    assert row["plan_value"] == 0.25 and row["fp.J.left_wheel"] == 0.7
    assert row["time.learn"] == 1.5 and row["version"] == "0.2.0+src.abc"
    assert list(row)[-5:] == ["elapsed", "error", "version", "finished_at", "condition_key"]
    (s,) = store.sessions()
    assert (s["workers"], s["backend"], s["finished"], s["seconds"]) == (2, "joblib", 3, 3.0)


def test_a_run_delivered_twice_is_stored_once(store):
    session = store.begin_session(1, "joblib")
    store.add(record(), session, 1, 1.0)
    store.add(record(outcome="detected"), session, 2, 2.0)
    assert store.count() == 1 and store.rows()[0]["outcome"] == "success"  # the first stays
    assert store.finished_keys() == {(CONDITIONS[0].key, 0)}


def test_errors_are_removed_to_be_run_again(store):
    session = store.begin_session(1, "joblib")
    store.add(record(run=0), session, 1, 1.0)
    store.add(record(run=1, outcome="error"), session, 2, 2.0)
    assert store.delete_errors() == 1
    assert store.finished_keys() == {(CONDITIONS[0].key, 0)}


def test_the_csv_follows_the_experiments_order_and_replaces_the_file(store, tmp_path):
    session = store.begin_session(1, "joblib")
    for c in CONDITIONS:
        store.add(record(c), session, 1, 1.0)
    path = tmp_path / "results.csv"
    path.write_text("old")
    order = {c.key: k for k, c in enumerate(CONDITIONS)}
    assert store.export_csv(path, order) == 2
    with path.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["method"] for r in rows] == ["mirl-t", "mirl"]
    assert not (tmp_path / "results.csv.tmp").exists()


def test_a_store_is_not_mixed_with_other_results(tmp_path):
    path = tmp_path / "results.sqlite"
    s = open_store(path, "fig4a", 7, resume=False)
    s.add(record(), s.begin_session(1, "joblib"), 1, 1.0)
    s.close()
    for experiment, seed, resume, needle in (
        ("fig4a", 7, False, "already holds 1 runs of fig4a; resume it"),
        ("fig3", 7, True, "holds runs of fig4a, not fig3"),
        ("fig4a", 8, True, "was started with `base_seed` 7, not 8"),
    ):
        with pytest.raises(StoreError, match=needle):
            open_store(path, experiment, seed, resume=resume)
    open_store(path, "fig4a", 7, resume=True).close()


def test_reading_results_changes_nothing(tmp_path):
    path = tmp_path / "results.sqlite"
    s = open_store(path, "fig4a", 0, resume=False)
    s.add(record(), s.begin_session(1, "joblib"), 1, 1.0)
    s.close()
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    meta, rows, sessions = load_results(tmp_path)  # the directory or the file
    assert meta == {"experiment": "fig4a", "base_seed": "0"} and len(rows) == len(sessions) == 1
    assert load_results(path)[1] == rows
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before


@pytest.mark.parametrize(
    "content, needle",
    [
        (b"", "empty file, not a results database"),
        (b"t,robot,row\n", "not an SQLite results database"),
        (b"SQLite format 3\x00" + b"\x00" * 84, "corrupt"),
    ],
)
def test_a_file_that_is_not_a_store_is_refused_and_left_as_it_is(tmp_path, content, needle):
    path = tmp_path / "results.sqlite"
    path.write_bytes(content)
    with pytest.raises(StoreError, match=needle):
        check_store(path)
    assert path.read_bytes() == content


def test_another_sqlite_database_is_not_a_store(tmp_path):
    path = tmp_path / "other.sqlite"
    with sqlite3.connect(path) as con:
        con.execute("CREATE TABLE t (x)")
    con.close()
    with pytest.raises(StoreError, match="not mirl's results"):
        check_store(path)
    check_store(tmp_path / "missing.sqlite")  # nothing yet: a new store may be made there
    with pytest.raises(StoreError, match="no such results database"):
        load_results(tmp_path / "missing.sqlite")


def test_a_store_has_one_writer_at_a_time(tmp_path):
    """Two sweeps writing one store ran every run twice, and one with another base seed set
    the store's seed under the other's rows; the second is refused until the first closes."""
    path = tmp_path / "results.sqlite"
    first = open_store(path, "fig4a", 7, resume=False)
    with pytest.raises(StoreError, match="another sweep is writing to it"):
        open_store(path, "fig4a", 8, resume=True)
    assert first.meta()["base_seed"] == "7"
    reader = ResultStore(path, read_only=True)  # `mirl report` reads while a sweep writes
    assert reader.count() == 0
    reader.close()
    first.close()
    open_store(path, "fig4a", 7, resume=True).close()
