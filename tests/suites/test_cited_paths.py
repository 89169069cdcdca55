"""Every file a comment, docstring or page cites exists, and every section it names is there.

Source comments and the docs point readers at tests, benchmarks, data files and sections of the
docs ("``tests/physics/test_patrol.py``", "docs/design.md, "BLAS threads""). Files move; a
citation of a path that no longer exists sends the reader nowhere. The CHANGELOG is history and
may name what has since moved, so it is not checked.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# the files whose citations are checked: the package, its docs, the README and the benchmarks
CITING = sorted(
    [*ROOT.joinpath("src").rglob("*.py"), *ROOT.joinpath("docs").rglob("*.md")]
    + [ROOT / "README.md", *ROOT.joinpath("benchmarks").glob("*.py")]
)

# a repository path: a top-level directory of the repository and at least one more part
PATH = re.compile(r"(?<![\w./-])((?:src|tests|benchmarks|docs)/[\w./-]*\w)")
# a section of a page cited as: docs/design.md, "Section title"
SECTION = re.compile(r"(docs/[\w-]+\.md), \"([^\"]+)\"")
# a section: a heading, or a paragraph's or list item's bold run-in title ("- **Which side: …**")
HEADING = re.compile(r"^(?:#+ |(?:- )?\*\*)(.+)$", re.M)


def _text(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def _cited_paths() -> list[tuple[str, str]]:
    return [(str(f.relative_to(ROOT)), m) for f in CITING for m in PATH.findall(_text(f))]


def test_the_citations_are_found():
    """The patterns see the citations that are there (a pattern that matched nothing would pass
    every check below)."""
    cited = {p for _, p in _cited_paths()}
    assert "tests/physics/test_patrol.py" in cited and "benchmarks/record_outputs.py" in cited
    assert len(cited) > 40
    assert any(s == "BLAS threads" for f in CITING for _, s in SECTION.findall(_text(f)))


def test_every_cited_path_exists():
    missing = sorted({f"{f}: {p}" for f, p in _cited_paths() if not (ROOT / p).exists()})
    assert not missing, "cited paths that do not exist:\n" + "\n".join(missing)


def test_every_cited_section_exists():
    """A section (a heading or a bold run-in title) is cited by the beginning of its title
    ("Which side" for "Which side: the lateral drift")."""
    headings: dict[str, list[str]] = {}
    missing = []
    for f in CITING:
        for page, cited in SECTION.findall(_text(f)):
            section = " ".join(re.sub(r"\n\s*#", " ", cited).split())  # a title across lines
            if page not in headings:
                headings[page] = HEADING.findall(_text(ROOT / page))
            if not any(h.startswith(section) for h in headings[page]):
                missing.append(f'{f.relative_to(ROOT)}: {page}, "{section}"')
    assert not missing, "cited sections that do not exist:\n" + "\n".join(sorted(set(missing)))


@pytest.mark.parametrize(
    ("text", "found"),
    [
        ("see ``tests/physics/test_patrol.py``.", ["tests/physics/test_patrol.py"]),
        ("(`python benchmarks/bench_physics.py`)", ["benchmarks/bench_physics.py"]),
        ("src/mirl/data/scenarios/boyd2.toml,", ["src/mirl/data/scenarios/boyd2.toml"]),
        ("mirl/tests/x.py or results/table1", []),
    ],
)
def test_the_path_pattern(text, found):
    assert PATH.findall(text) == found
