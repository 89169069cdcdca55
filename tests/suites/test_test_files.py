"""Every module has its test file: the tests mirror the package, so a module
``src/mirl/<stage>/<module>.py`` is tested in ``tests/<stage>/test_<module>.py`` (a top-level
module in ``tests/test_<module>.py``; a private module's leading underscore dropped), or its
entry below says where it is tested instead and why a file of its own would add nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

import mirl

ROOT = Path(mirl.__file__).parent
TESTS = ROOT.parents[1] / "tests"

# "path/in/package.py" -> (the test file that tests it, the name through which it does, why the
# module has no file of its own). The file must exist and use that name; an entry whose module
# has gained its own test file, or no longer exists, fails (the list only shrinks).
TESTED_ELSEWHERE = {
    "world/actions.py": (
        "tests/world/test_domain.py",
        "ACTIONS",
        "names and numbers only (the actions, their indices, the headings); the domain's "
        "tests check every use of them",
    ),
    "world/_resources.py": (
        "tests/world/test_catalog.py",
        "load_map",
        "the shipped-name-or-file reading behind load_map and load_scenario; its messages are "
        "tested through both",
    ),
    "world/scenario_sections.py": (
        "tests/world/test_scenario.py",
        "load_scenario",
        "the readers of a scenario file's sections, called only by load_scenario; every "
        "section's fields and refusals are tested through it, where the messages name the file",
    ),
    "observations/_csv.py": (
        "tests/observations/test_grid_csv.py",
        "read_csv",
        "the CSV plumbing (header, pyarrow reading, line numbers, writing) shared by the grid "
        "and pose readers, tested through both against their row-by-row references",
    ),
}

# Modules other work is rewriting at the moment (the fault verdicts): their test files come
# with that work. A module listed here that has its test file fails, so the list only shrinks.
PENDING: set[str] = set()


def _modules() -> list[str]:
    return sorted(
        p.relative_to(ROOT).as_posix()
        for p in ROOT.rglob("*.py")
        if p.name not in ("__init__.py", "__main__.py")
    )


def expected_test_file(module: str) -> Path:
    """Where the tests of ``module`` ("stage/module.py") belong."""
    path = Path(module)
    return TESTS / path.parent / f"test_{path.stem.lstrip('_')}.py"


def test_every_module_has_its_test_file_or_a_reason():
    missing = [
        f"{m}: no {expected_test_file(m).relative_to(TESTS.parent)}"
        for m in _modules()
        if not expected_test_file(m).exists() and m not in TESTED_ELSEWHERE and m not in PENDING
    ]
    assert missing == []


def test_no_module_listed_has_its_own_file_or_is_gone():
    listed = set(TESTED_ELSEWHERE) | PENDING
    assert sorted(listed & set(TESTED_ELSEWHERE) & PENDING) == []  # one list each
    stale = [m for m in sorted(listed) if m not in _modules() or expected_test_file(m).exists()]
    assert stale == []


@pytest.mark.parametrize("module", sorted(TESTED_ELSEWHERE))
def test_the_file_named_tests_the_module(module):
    where, through, why = TESTED_ELSEWHERE[module]
    path = TESTS.parent / where
    assert path.exists(), where
    assert through in path.read_text(), f"{where} does not use {through}"
    assert len(why.split()) >= 8, "say why the module needs no file of its own"


def test_the_rule_maps_modules_to_their_files():
    assert expected_test_file("learning/irl.py") == TESTS / "learning" / "test_irl.py"
    assert expected_test_file("mdp.py") == TESTS / "test_mdp.py"
    assert expected_test_file("_registry.py") == TESTS / "test_registry.py"
