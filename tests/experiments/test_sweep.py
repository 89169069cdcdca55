"""Experiment harness: exactly-once storage under SIGKILL + resume, worker-count independence,
a local Dask scheduler, reports, and the CLI's one-line errors. Uses the built-in ``selftest``
experiment (a deterministic fake run), so nothing here depends on the learning code."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pytest

from mirl._validation import OptionError
from mirl.cli import main
from mirl.experiments.conditions import EXPERIMENTS, Condition, StoreError, run_seed, selftest_run
from mirl.experiments.store import load_results
from mirl.experiments.sweep import run_experiment

QUIET = {"log": lambda msg: None}


def sweep(**options):
    """Sweep options as the tests give them: quiet, one worker unless told."""
    return {"progress": False, "workers": 1} | options
VOLATILE = {"elapsed", "finished_at"}  # timing columns differ between identical runs


def comparable(rows: list[dict]) -> list[dict]:
    return sorted(
        ({k: v for k, v in r.items() if k not in VOLATILE and not k.startswith("time.")}
         for r in rows),
        key=lambda r: (r["condition_key"], r["run"]),
    )  # fmt: skip


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> list[dict]:
    """The uninterrupted, single-worker selftest sweep (10 runs per condition)."""
    out = tmp_path_factory.mktemp("ref")
    run_experiment("selftest", out, sweep(runs=10, workers=1), **QUIET)
    return comparable(load_results(out)[1])


def test_condition_key_is_stable_and_round_trips():
    c = Condition("mirl", "boyd2", 0.14, 300, p=0.9)
    assert (
        c.key == '{"method":"mirl","obs_steps":300,"observability":0.14,"p":0.9,"scenario":"boyd2"}'
    )
    assert Condition.from_key(c.key) == c


def test_seeds_depend_on_run_only_and_are_distinct():
    seeds = [run_seed(0, i) for i in range(1000)]
    assert len(set(seeds)) == 1000
    assert run_seed(0, 7) == run_seed(0, 7) != run_seed(1, 7)


def test_one_and_two_workers_store_identical_rows(tmp_path, reference):
    run_experiment("selftest", tmp_path, sweep(runs=10, workers=2), **QUIET)
    assert comparable(load_results(tmp_path)[1]) == reference
    assert (tmp_path / "results.csv").read_text().count("\n") == len(reference) + 1


def test_sigkill_then_resume_stores_each_run_exactly_once(tmp_path, reference):
    env = {**os.environ, "MIRL_SELFTEST_SLEEP": "0.05"}
    cmd = [sys.executable, "-m", "mirl.cli", "experiment", "selftest", "--runs", "10",
           "--workers", "2", "--out", str(tmp_path), "--quiet"]  # fmt: skip
    # its own session, so the kill reaches the parent and its joblib workers at once
    proc = subprocess.Popen(cmd, env=env, start_new_session=True, stderr=subprocess.DEVNULL)
    db = tmp_path / "results.sqlite"
    deadline = time.monotonic() + 60
    n = 0
    while n < 8 and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.02)
        n = _count(db)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    killed_at = _count(db)
    assert 0 < killed_at < len(reference), "the kill should land mid-sweep"
    con = sqlite3.connect(db)
    assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
    con.close()

    options = sweep(runs=10, workers=2, resume=True)
    summary = run_experiment("selftest", tmp_path, options, **QUIET)
    assert summary.already_done == killed_at
    assert summary.finished == len(reference) - killed_at
    con = sqlite3.connect(db)
    total, distinct = con.execute(
        "SELECT COUNT(*), COUNT(DISTINCT condition_key || '#' || run) FROM runs"
    ).fetchone()
    con.close()
    assert total == distinct == len(reference)
    assert comparable(load_results(tmp_path)[1]) == reference


def _count(db: Path) -> int:
    if not db.exists():
        return 0
    try:
        con = sqlite3.connect(db, timeout=5)
        try:
            return int(con.execute("SELECT COUNT(*) FROM runs").fetchone()[0])
        finally:
            con.close()
    except sqlite3.OperationalError:  # table not created yet
        return 0


def test_a_resume_under_another_protocol_is_refused_not_mixed_in(tmp_path):
    # its runs would be stored under new keys beside the others and reported as the same rows
    from mirl.experiments.conditions import in_world, with_protocol
    from mirl.experiments.sweep import _check_same_grid

    fig4b = EXPERIMENTS["fig4b"]
    started = with_protocol(fig4b, "adaptive", True)  # mirl experiment's default
    stored = {(c.key, 0) for c in started.conditions}
    _check_same_grid(started, stored, tmp_path)  # the same grid: resumed
    _check_same_grid(started, stored | {(started.conditions[0].key, 1)}, tmp_path)
    cases = [
        (with_protocol(fig4b, "adaptive", False), "relearn=True, not relearn=False as asked"),
        (with_protocol(fig4b, "value", True), "go_rule='adaptive', not go_rule='value' as asked"),
        (in_world(started, "physics"), "world='grid', not world='physics' as asked (`world`)"),
    ]
    for asked, needle in cases:
        with pytest.raises(StoreError, match="holds runs of fig4b with") as info:
            _check_same_grid(asked, stored, tmp_path)
        assert needle in str(info.value)


def test_a_dask_scheduler_that_does_not_answer_is_named(tmp_path, monkeypatch):
    distributed = pytest.importorskip("distributed")

    def refused(address, timeout):
        raise TimeoutError(f"Timed out trying to connect to tcp://{address} after {timeout}")

    monkeypatch.setattr(distributed, "Client", refused)
    out = tmp_path / "sweep"
    with pytest.raises(OptionError, match=r"^`dask_scheduler` 127.0.0.1:1: no Dask scheduler"):
        run_experiment("selftest", out, {"runs": 1, "dask_scheduler": "127.0.0.1:1"})
    assert not out.exists()  # nothing of a sweep that never started is left behind


def test_local_dask_scheduler_gives_the_same_rows(tmp_path, reference):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        host="127.0.0.1", protocol="tcp", n_workers=1, threads_per_worker=2,
        processes=False, dashboard_address=None,
    ) as cluster:  # fmt: skip
        options = sweep(runs=10, workers=None, dask_scheduler=cluster.scheduler_address)
        summary = run_experiment("selftest", tmp_path, options, **QUIET)
    assert summary.workers == 2
    assert comparable(load_results(tmp_path)[1]) == reference


def failing_run(condition: Condition, seed: int) -> dict:
    if condition.method == "a" and seed == run_seed(0, 1):
        raise RuntimeError("boom")
    return selftest_run(condition, seed)


def test_failed_runs_are_recorded_then_retried_on_resume(tmp_path, reference):
    bad = replace(EXPERIMENTS["selftest"], run_function=failing_run)
    summary = run_experiment(bad, tmp_path, sweep(runs=10), **QUIET)
    assert summary.outcomes["error"] == 2  # method a at both observabilities
    rows = load_results(tmp_path)[1]
    assert {r["error"] for r in rows if r["outcome"] == "error"} == {"RuntimeError: boom"}
    summary = run_experiment("selftest", tmp_path, sweep(runs=10, resume=True), **QUIET)
    assert summary.finished == 2
    assert comparable(load_results(tmp_path)[1]) == reference


def test_existing_results_need_resume_and_the_same_experiment(tmp_path):
    run_experiment("selftest", tmp_path, sweep(runs=1), **QUIET)
    with pytest.raises(StoreError, match="`resume`"):
        run_experiment("selftest", tmp_path, sweep(runs=1), **QUIET)
    with pytest.raises(StoreError, match="not table1"):
        run_experiment("table1", tmp_path, sweep(runs=1, resume=True), **QUIET)
    with pytest.raises(StoreError, match="`base_seed`"):
        run_experiment("selftest", tmp_path, sweep(runs=1, resume=True, base_seed=3), **QUIET)
    grown = run_experiment("selftest", tmp_path, sweep(runs=2, resume=True), **QUIET)
    assert (grown.already_done, grown.finished) == (4, 4)


@pytest.mark.parametrize("name", ["fig3", "fig4a", "fig4b", "fig4c", "table1"])
def test_report_from_a_tiny_database(tmp_path, name):
    fake = replace(EXPERIMENTS[name], run_function=selftest_run)
    run_experiment(fake, tmp_path / name, sweep(runs=3), **QUIET)
    assert main(["report", str(tmp_path)]) == 0
    text = (tmp_path / "report.md").read_text()
    assert f"## {name}" in text and "**Paper:**" in text
    if name == "table1":
        assert "0.60 (n=10)" in text and "0.20 (n=10)" in text
    for ext in ("png", "svg"):
        assert (tmp_path / name / "figures" / f"{name}.{ext}").stat().st_size > 1000
    assert f"]({name}/figures/{name}.png)" in text
    assert "nan" not in text
    if name == "fig4b":
        assert "J left vs right wheel t =" in text
    if name in ("fig4b", "fig4c"):  # the report's "±" means s.e. unless it says std: it does
        assert "mean ± std over runs" in text


def test_cli_one_line_errors(tmp_path, capsys):
    with pytest.raises(SystemExit, match="2"):  # argparse refuses the name
        main(["experiment", "fig9", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "unknown experiment 'fig9'" in err
    assert main(["report", str(tmp_path / "nothing")]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    assert main(["experiment", "selftest", "--runs", "1", "--out", str(tmp_path), "--quiet"]) == 0
    assert main(["experiment", "selftest", "--runs", "1", "--out", str(tmp_path)]) == 2
    assert "--resume" in capsys.readouterr().err


def test_report_takes_the_database_file_and_names_any_other_file(tmp_path, capsys):
    run_experiment(
        replace(EXPERIMENTS["table1"], run_function=selftest_run), tmp_path, sweep(runs=1), **QUIET
    )
    assert main(["report", str(tmp_path / "results.sqlite")]) == 0  # its directory's report
    assert (tmp_path / "report.md").exists()
    other = tmp_path / "runs.csv"
    other.write_text("a,b\n")
    capsys.readouterr()
    assert main(["report", str(other)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "a file, not an experiment's results directory" in err
    assert main(["report", str(tmp_path / "no-such-run")]) == 2  # a mistyped directory
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.rstrip().endswith("no-such-run: no such directory"), err


@pytest.mark.parametrize("world", ["grid", "physics"])
def test_split_version_gives_back_the_code_fingerprint_and_the_worlds_part(world: str) -> None:
    from mirl.experiments.conditions import code_version
    from mirl.experiments.sweep import run_version, split_version
    from mirl.worlds import get_world

    cond = replace(next(iter(EXPERIMENTS["selftest"].conditions)), world=world)
    code, extra = split_version(run_version(cond))
    assert code == code_version()
    assert extra == get_world(world).load().version()


def test_split_version_leaves_a_version_of_another_form_whole() -> None:
    from mirl.experiments.sweep import split_version

    assert split_version("0.1.0") == ("0.1.0", "")
    assert split_version("0.2.0+src.0123456789+mujoco.3.1.0") == (
        "0.2.0+src.0123456789", "mujoco.3.1.0",
    )  # fmt: skip
