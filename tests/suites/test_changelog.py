"""The CHANGELOG, the package's version and the docstrings' version notes agree.

The version is ``pyproject.toml``'s (what an install records); a development version
(``0.2.0.dev0``) is the release the CHANGELOG's "Unreleased" section becomes. A
``versionchanged``/``versionadded`` note names a release the CHANGELOG has, or that next one. What
the "Unreleased" section adds is something mirl has: a flag it offers is one the command line
takes (an "Added" entry once offered ``--relearn`` after "Changed" had removed it).
"""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

from packaging.version import Version

ROOT = Path(__file__).resolve().parents[2]
CHANGELOG = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
VERSION = Version(tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"])
NOTE = re.compile(r"\.\. (?:versionchanged|versionadded|deprecated):: (\S+)")


def _sections(text: str, level: str) -> dict[str, str]:
    """The text under each heading of ``level`` (``##``), by heading."""
    parts = re.split(rf"^{level} (.+)$", text, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2], strict=True))


RELEASES = _sections(CHANGELOG, "##")
RELEASED = [Version(h.strip("[]")) for h in RELEASES if h != "[Unreleased]"]


def _next_release() -> Version:
    """The release the "Unreleased" section becomes: the package's version without its
    development suffix."""
    return Version(VERSION.base_version)


def test_the_package_version_is_the_next_release_or_the_latest_one():
    assert RELEASED, "the CHANGELOG has no released version"
    if VERSION.is_devrelease:  # work towards the next release: the "Unreleased" section
        assert "[Unreleased]" in RELEASES
        assert _next_release() > max(RELEASED)
        assert f"released as {_next_release()}" in RELEASES["[Unreleased]"]
        assert f"`{VERSION}`" in RELEASES["[Unreleased]"]
    else:  # a release: the newest section of the CHANGELOG
        assert VERSION == max(RELEASED)


def test_every_version_note_names_a_release_the_changelog_has():
    known = {*RELEASED, _next_release()}
    notes = [
        (path.relative_to(ROOT), Version(v))
        for path in (ROOT / "src").rglob("*.py")
        for v in NOTE.findall(path.read_text(encoding="utf-8"))
    ]
    assert notes, "no version notes found: the pattern is wrong"
    wrong = [f"{path}: {v}" for path, v in notes if v not in known]
    assert not wrong, f"version notes of releases the CHANGELOG does not have: {wrong}"


def _flags() -> set[str]:
    """Every option string of every sub-command of ``mirl``."""
    import argparse

    from mirl.cli.parser import build_parser

    parser = build_parser()
    subs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return {s for p in subs.choices.values() for a in p._actions for s in a.option_strings}


def test_what_the_unreleased_section_adds_the_command_line_takes():
    added = _sections(RELEASES["[Unreleased]"], "###")["Added"]
    offered = set()
    for span in re.findall(r"`([^`]+)`", added):  # a flag, or a mirl command with its flags
        if span.startswith("--") or span.startswith("mirl "):
            offered |= set(re.findall(r"(?<![\w-])(--[a-z][a-z-]*)", span))
    assert "--go-rule" in offered  # the pattern finds the flags that are there
    missing = sorted(offered - _flags())
    assert not missing, f"the CHANGELOG's Added offers flags mirl does not take: {missing}"


def test_the_unreleased_section_has_each_kind_of_change_once():
    kinds = re.findall(r"^### (.+)$", RELEASES["[Unreleased]"], flags=re.M)
    assert len(kinds) == len(set(kinds)), kinds
    assert set(kinds) <= {"Added", "Changed", "Deprecated", "Removed", "Fixed", "Security"}
