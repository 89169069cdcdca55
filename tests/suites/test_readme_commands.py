"""Every shell example of the README runs as written: each ``mirl`` line of its command blocks,
in order, in one fresh directory (later lines read what earlier ones wrote). The set-up and
install blocks are what CI itself runs; the physics world's lines and the 20-run experiment are
slow and run with ``-m slow``."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

import mirl
from mirl.cli import main

README = Path(mirl.__file__).resolve().parents[2] / "README.md"


def _commands() -> list[tuple[str, list[str]]]:
    """Every ``mirl`` command of the README's bash blocks, comments and continuations removed."""
    out = []
    for block in re.findall(r"```bash\n(.*?)```", README.read_text(), re.S):
        for line in block.replace("\\\n", " ").splitlines():
            argv = shlex.split(line, comments=True)
            if argv and argv[0] == "mirl":
                out.append((line.split("#")[0].strip(), argv[1:]))
    return out


def _slow(argv: list[str]) -> bool:
    return "physics" in argv or argv[0] in ("experiment", "report")


COMMANDS = _commands()


def test_the_readme_has_shell_examples():
    assert len(COMMANDS) >= 8
    assert any(not _slow(argv) for _, argv in COMMANDS)


def _run_in_order(tmp_path, monkeypatch, capsys, keep) -> int:
    monkeypatch.chdir(tmp_path)
    ran = 0
    for line, argv in COMMANDS:
        if not keep(argv):
            continue
        code = main(argv)
        err = capsys.readouterr().err
        assert code == 0, f"{line}: exit {code}: {err}"
        assert "Traceback" not in err, line
        ran += 1
    return ran


def test_readme_commands_run_as_written(tmp_path, monkeypatch, capsys):
    assert _run_in_order(tmp_path, monkeypatch, capsys, lambda argv: not _slow(argv)) > 0


@pytest.mark.slow
def test_every_readme_command_runs_as_written(tmp_path, monkeypatch, capsys):
    assert _run_in_order(tmp_path, monkeypatch, capsys, lambda argv: True) == len(COMMANDS)
