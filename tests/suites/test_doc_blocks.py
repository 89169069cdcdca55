"""What the docs show a command printing is what it prints, and their examples run as written.

A block of output in the README or a page of the docs is marked by the commands that print it::

    <!-- output of: mirl simulate ... && mirl learn ... -->
    ```text
    ...
    ```

The commands run in order in one fresh directory; every line of the block must be a line of the
last command's output, in the same order (a block may leave lines out, never change one).
Figures of the physical world are not marked: they differ between CPUs and MuJoCo releases, and
the docs give them as distributions over seeds (docs/results.md).

The getting-started page's `mirl` lines and Python examples run as written, as the README's do
(tests/suites/test_readme_commands.py, tests/suites/test_architecture.py); the physics world's
lines and the experiment are slow.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from mirl.cli import main

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
GETTING_STARTED = ROOT / "docs" / "getting-started.md"
MARKED = re.compile(r"<!-- output of: (.+?) -->\n```\w*\n(.*?)```", re.S)


def _blocks() -> list:
    return [
        pytest.param(commands, block, id=f"{page.name}:{k}")
        for page in PAGES
        for k, (commands, block) in enumerate(MARKED.findall(page.read_text(encoding="utf-8")))
    ]


BLOCKS = _blocks()


def test_the_docs_mark_their_output_blocks():
    """The pattern finds the blocks (a pattern that matched nothing would pass every check)."""
    pages = {str(p.id).split(":")[0] for p in BLOCKS}
    assert {"README.md", "getting-started.md"} <= pages


def _run(argv: list[str], capsys) -> str:
    assert argv[0] == "mirl", argv
    code = main(argv[1:])
    out, err = capsys.readouterr()
    assert code == 0, f"{shlex.join(argv)}: exit {code}: {err}"
    return out


@pytest.mark.parametrize(("commands", "block"), BLOCKS)
def test_an_output_block_is_what_its_commands_print(commands, block, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    out = ""
    for command in commands.split("&&"):
        out = _run(shlex.split(command), capsys)
    printed = [line.rstrip() for line in out.splitlines()]
    at = 0
    for line in block.rstrip("\n").splitlines():
        try:
            at = printed.index(line.rstrip(), at) + 1
        except ValueError:
            pytest.fail(f"`{commands}` does not print, at this point of its output:\n{line}\n"
                        f"it prints:\n{out}")  # fmt: skip


def _getting_started_commands() -> list[list[str]]:
    text = GETTING_STARTED.read_text(encoding="utf-8")
    out = []
    for block in re.findall(r"```bash\n(.*?)```", text, re.S):
        for line in block.replace("\\\n", " ").splitlines():
            argv = shlex.split(line, comments=True)
            if argv and argv[0] == "mirl":
                out.append(argv)
    return out


def _slow(argv: list[str]) -> bool:
    return "physics" in argv or argv[1] in ("experiment", "report")


@pytest.mark.parametrize("slow", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_the_getting_started_commands_run_as_written(slow, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    commands = _getting_started_commands()
    assert len(commands) >= 10
    ran = [_run(argv, capsys) for argv in commands if slow or not _slow(argv)]
    assert ran


def test_the_getting_started_python_runs_as_written(tmp_path, monkeypatch):
    pytest.importorskip("gymnasium")
    monkeypatch.chdir(tmp_path)
    blocks = re.findall(r"```python\n(.*?)```", GETTING_STARTED.read_text(encoding="utf-8"), re.S)
    assert len(blocks) >= 2
    for block in blocks:
        exec(compile(block, str(GETTING_STARTED), "exec"), {})
