"""`report.md` and the figures beside it: `mirl report` says which files it wrote."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from mirl.cli import main
from mirl.experiments.conditions import EXPERIMENTS, selftest_run
from mirl.experiments.sweep import run_experiment
from mirl.viz.report import write_report_and_figures

QUIET = {"log": lambda message: None}
ONE = {"progress": False, "workers": 1}  # sweep options: quiet, one worker


def _tiny(root: Path, name: str) -> None:
    """A few fake runs of experiment ``name`` under ``root/name``."""
    fake = replace(EXPERIMENTS[name], run_function=selftest_run)
    run_experiment(fake, root / name, ONE | {"runs": 2}, **QUIET)


def test_report_names_the_report_and_every_figure_it_drew(tmp_path, capsys):
    for name in ("table1", "fig4a"):
        _tiny(tmp_path, name)
    assert main(["report", str(tmp_path)]) == 0
    said = capsys.readouterr().out.splitlines()
    figures = {
        tmp_path / name / "figures" / f"{name}.{ext}"
        for name in ("table1", "fig4a")
        for ext in ("png", "svg")
    }
    assert said[0] == f"wrote {tmp_path / 'report.md'}"
    assert {Path(line.removeprefix("wrote ")) for line in said[1:]} == figures
    assert all(line.startswith("wrote ") for line in said) and len(said) == 5
    # every figure in the figures directories is one it named, and the report shows the PNGs
    on_disk = {p for p in tmp_path.glob("*/figures/*")}
    assert on_disk == figures
    text = (tmp_path / "report.md").read_text()
    assert all(f"]({p.relative_to(tmp_path).as_posix()})" in text for p in figures
               if p.suffix == ".png")  # fmt: skip


def test_a_report_drawn_again_names_the_figures_it_drew_over(tmp_path):
    _tiny(tmp_path, "table1")
    first = write_report_and_figures(tmp_path)
    again = write_report_and_figures(tmp_path)
    assert first == again and len(first.figures) == 2


def test_a_report_without_figures_says_so(tmp_path, capsys):
    run_experiment("selftest", tmp_path, ONE | {"runs": 1}, **QUIET)
    assert main(["report", str(tmp_path)]) == 0
    said = capsys.readouterr().out.splitlines()
    assert said[0] == f"wrote {tmp_path / 'report.md'}" and "no figures" in said[1]


def test_a_report_of_an_interrupted_sweep_says_what_is_missing(tmp_path):
    """A sweep stopped before its last runs (emulated by deleting two stored runs) is reported
    short of what it was asked for; finished, and resumed with fewer runs, it is not."""
    import sqlite3

    _tiny(tmp_path, "table1")
    report = tmp_path / "table1" / "report.md"
    write_report_and_figures(tmp_path / "table1")
    assert "missing" not in report.read_text()
    con = sqlite3.connect(tmp_path / "table1" / "results.sqlite")
    n = con.execute("SELECT COUNT(*) FROM runs").fetchone()[0]
    with con:
        con.execute(
            "DELETE FROM runs WHERE rowid IN (SELECT rowid FROM runs WHERE run = 1 LIMIT 2)"
        )
    con.close()
    write_report_and_figures(tmp_path / "table1")
    assert f"2 of the {n} runs the sweep was asked for are missing" in report.read_text()
    fake = replace(EXPERIMENTS["table1"], run_function=selftest_run)
    run_experiment(fake, tmp_path / "table1", ONE | {"runs": 1, "resume": True}, **QUIET)
    write_report_and_figures(tmp_path / "table1")
    assert "2 of the" in report.read_text()  # still asked for 2 runs a condition
    run_experiment(fake, tmp_path / "table1", ONE | {"runs": 2, "resume": True}, **QUIET)
    write_report_and_figures(tmp_path / "table1")
    assert "missing" not in report.read_text()
