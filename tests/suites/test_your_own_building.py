"""The worked example of docs/your-own-building.md, run as the page gives it: every ``mirl``
command of its bash blocks, in order, on the scenario file the page includes."""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path

import pytest

from mirl.cli import main

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "your-own-building.md"
SCENARIO = ROOT / "docs" / "examples" / "turtlebot3-world.toml"


def _commands() -> list[list[str]]:
    blocks = re.findall(r"```bash\n(.*?)```", PAGE.read_text(), flags=re.S)
    lines = [ln.strip() for block in blocks for ln in block.splitlines()]
    return [shlex.split(ln)[1:] for ln in lines if ln.startswith("mirl ")]


def test_the_page_runs_every_step():
    steps = [argv[0] for argv in _commands()]
    assert steps == ["show-map", "show-map", "show-map", "simulate", "convert", "learn", "run"]


def test_your_own_building_end_to_end(tmp_path, monkeypatch, capsys):
    shutil.copy(SCENARIO, tmp_path / "turtlebot3-world.toml")
    monkeypatch.chdir(tmp_path)
    out = {}
    for argv in _commands():
        assert main(argv) == 0, argv
        out.setdefault(argv[0], []).append(capsys.readouterr().out)
    plain, finer, scenario = out["show-map"]
    assert "39x39 cells of 0.5 m, 40 patroller cells, 160 patroller states" in plain
    assert "cells of 0.25 m" in finer
    assert "L's start: cell (18, 15), x = -2.25, y = -0.05 m" in scenario
    assert "in L's line of sight" in scenario
    assert (tmp_path / "map.png").stat().st_size > 0 and (tmp_path / "scenario.png").exists()
    assert re.search(r"J: \d+ poses read", out["convert"][0])
    assert "robot J" in out["learn"][0]
    assert "outcome" in out["run"][0] and (tmp_path / "run.png").exists()


@pytest.mark.parametrize(
    "field, old, new",
    [
        ("observer.start", "x = -2.25, y = 0.0", "x = -1.25, y = 0.0"),
        ("robots[0].start", "x = 1.75, y = 0.5, yaw", "x = 1.25, y = 0.0, yaw"),
    ],
)
def test_a_point_on_a_wall_names_the_field(tmp_path, capsys, field, old, new):
    path = tmp_path / "on-a-wall.toml"
    assert old in SCENARIO.read_text()
    path.write_text(SCENARIO.read_text().replace(old, new))
    assert main(["show-map", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{field}: " in err and "Traceback" not in err
