"""The API site renders its cross-references: the site's Griffe extension
(``docs/griffe_sphinx_roles.py``) turns every Sphinx role of a docstring into a link, or into
inline code where the site renders no page for the target; no role names a thing mirl does not
have, and none is left as literal text. The extension runs here over the package as
``mkdocs build`` loads it, which takes a second where a whole build takes a minute."""

from __future__ import annotations

import importlib.util
import logging
import re
import sys
from pathlib import Path

import griffe
import pytest

import mirl

DOCS = Path(mirl.__file__).resolve().parents[2] / "docs"
# any reStructuredText role, not only the Python domain's the extension rewrites (:math:, :ref:
# would show as literal text too)
ANY_ROLE = re.compile(r":(?:[a-z]+:)?[a-z]+:`[^`]+`")


def _extension():
    spec = importlib.util.spec_from_file_location(
        "griffe_sphinx_roles", DOCS / "griffe_sphinx_roles.py"
    )
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(spec.name, module)
    spec.loader.exec_module(module)
    return module


def _load(package: str, path: Path, extension) -> griffe.Module:
    loaded = griffe.load(
        package,
        search_paths=[str(path)],
        extensions=griffe.load_extensions(extension.SphinxRoles),
        docstring_parser="numpy",
    )
    assert isinstance(loaded, griffe.Module)
    return loaded


def _docstrings(obj):
    if obj.docstring is not None:
        yield obj.path, obj.docstring.value
    for member in obj.members.values():
        if not member.is_alias:
            yield from _docstrings(member)


def test_every_role_in_mirl_resolves_and_none_stays_literal(caplog):
    extension = _extension()
    with caplog.at_level(logging.WARNING, logger=extension.logger.name):
        package = _load("mirl", Path(mirl.__file__).parents[1], extension)
    assert [r.getMessage() for r in caplog.records] == []  # a role naming what mirl lacks
    literal = [
        f"{path}: {match}"
        for path, text in _docstrings(package)
        for match in ANY_ROLE.findall(text)
    ]
    assert literal == []


def test_every_api_page_renders_a_module_that_exists():
    roots = _extension()._rendered_roots()
    assert "mirl" in roots and "mirl.learning" in roots
    for root in roots:
        importlib.import_module(root)


@pytest.fixture
def toy(tmp_path, monkeypatch):
    """A two-module package and one API page rendering it."""
    package = tmp_path / "src" / "toypkg"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text(
        '"""Toy. :func:`~toypkg.core.solve`, :class:`the thing <toypkg.core.Thing>`,\n'
        ":func:`numpy.dot`, :exc:`ValueError`, :func:`toypkg.core._private`,\n"
        ':data:`toypkg.core.UNDOCUMENTED`, :func:`toypkg.core.missing`."""\n'
    )
    (package / "core.py").write_text(
        '"""Core."""\n'
        '__all__ = ["solve", "Thing", "UNDOCUMENTED"]\n'
        "UNDOCUMENTED = 1\n"
        'def solve():\n    """Solve with :meth:`Thing.run` (:py:attr:`Thing.size`)."""\n'
        'class Thing:\n    """A thing."""\n'
        '    size: int\n    """Its size."""\n'
        '    def run(self):\n        """Run."""\n'
        'def _private():\n    """Private."""\n'
    )
    pages = tmp_path / "api"
    pages.mkdir()
    (pages / "toypkg.md").write_text("# toypkg\n\n::: toypkg\n")
    (pages / "core.md").write_text("# toypkg.core\n\n::: toypkg.core\n")
    extension = _extension()
    monkeypatch.setattr(extension, "API_PAGES", pages)
    return tmp_path / "src", extension


def test_roles_become_links_code_or_a_warning(toy, caplog):
    src, extension = toy
    with caplog.at_level(logging.WARNING, logger=extension.logger.name):
        package = _load("toypkg", src, extension)
    docs = dict(_docstrings(package))
    top = docs["toypkg"]
    assert "[`solve()`][toypkg.core.solve]" in top
    assert "[`the thing`][toypkg.core.Thing]" in top
    assert "`numpy.dot()`" in top and "[`numpy.dot()`]" not in top  # another package: code
    assert "`ValueError`" in top and "[`ValueError`]" not in top  # Python's own: code
    assert "`toypkg.core._private()`" in top and "][toypkg.core._private]" not in top
    assert "`toypkg.core.UNDOCUMENTED`" in top and "][toypkg.core.UNDOCUMENTED]" not in top
    assert "`toypkg.core.missing()`" in top
    assert not ANY_ROLE.search(top)
    # relative to the object's module, as Sphinx resolves them; the py: domain prefix too
    solve = docs["toypkg.core.solve"]
    assert "[`Thing.run()`][toypkg.core.Thing.run]" in solve
    assert "[`Thing.size`][toypkg.core.Thing.size]" in solve
    warnings = [r.getMessage() for r in caplog.records]
    assert warnings == [
        "toypkg: the func role names 'toypkg.core.missing', which toypkg does not have"
    ]
