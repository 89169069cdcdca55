"""A Griffe extension that renders the docstrings' Sphinx roles as links on the API site.

mirl's docstrings follow numpydoc, whose cross-references are Sphinx roles
(``:func:`~mirl.learning.learn.learn```): they read well in ``help()`` and in an editor, and
numpydoc's own tools understand them. mkdocstrings renders Markdown, where a role would show as
literal text. This extension rewrites each role, once the package is loaded, into the Markdown
cross-reference of mkdocs-autorefs (``[`learn`][mirl.learning.learn.learn]``), resolving the
target as Sphinx does: as written, then relative to the object's module and class. A target the
site does not render (a private module, a name outside ``__all__``, an undocumented constant,
another package) becomes inline code, so no link can break; a target that names nothing is
logged as a warning, which ``mkdocs build --strict`` turns into a failed build.

Why by hand: Griffe reads Google, NumPy and Sphinx *sections*, but no Griffe extension or
mkdocstrings option translates Sphinx *roles* inside the text (mkdocstrings' maintainers point
to a docstring pre-processing extension such as this one).
"""

from __future__ import annotations

import builtins
import logging
import re
from pathlib import Path
from typing import Any

import griffe

logger = logging.getLogger("mkdocs.plugins.griffe_sphinx_roles")

ROLE = re.compile(r":(?:py:)?(func|class|mod|meth|attr|data|exc|obj|const):`([^`]+)`")
CALLABLE_ROLES = {"func", "meth"}
API_PAGES = Path(__file__).parent / "api"  # the pages beside this file


def _rendered_roots() -> tuple[str, ...]:
    """The modules the API pages render with their submodules (``::: mirl.world``); the
    top-level page (``::: mirl``, no submodules) renders the package's own members only."""
    roots = []
    for page in sorted(API_PAGES.glob("*.md")):
        for line in page.read_text().splitlines():
            if line.startswith("::: "):
                roots.append(line[4:].strip())
    return tuple(roots)


def _lookup(package: griffe.Module, path: str) -> griffe.Object | griffe.Alias | None:
    root, _, rest = path.partition(".")
    if root != package.name:
        return None
    try:
        return package.get_member(rest) if rest else package
    except (KeyError, ValueError, griffe.AliasResolutionError, griffe.CyclicAliasError):
        return _lazy_export(package, path)


def _lazy_export(package: griffe.Module, path: str) -> griffe.Object | griffe.Alias | None:
    """A name a package exports lazily (PEP 562): its ``_EXPORTS`` dict maps the name to the
    module that defines it, which is where the site renders it."""
    module_path, _, name = path.rpartition(".")
    module = _lookup(package, module_path) if module_path.count(".") else None
    if module_path == package.name:
        module = package
    try:
        exports = getattr(module, "members", {}).get("_EXPORTS") if module is not None else None
    except (griffe.AliasResolutionError, griffe.CyclicAliasError):
        return None  # a module's import of another package (``argparse`` in mirl.cli.flags)
    value = getattr(exports, "value", None)
    if value is None:
        return None
    found = re.search(rf"[\"']{re.escape(name)}[\"']\s*:\s*[\"']([\w.]+)[\"']", str(value))
    return _lookup(package, f"{found.group(1)}.{name}") if found else None


def _candidates(target: str, obj: griffe.Object) -> list[str]:
    """Where Sphinx would look for ``target`` from inside ``obj``."""
    paths = [target]
    scope: Any = obj
    while scope is not None:
        paths.append(f"{scope.path}.{target}")
        scope = scope.parent
    return paths


def _rendered(found: griffe.Object | griffe.Alias, roots: tuple[str, ...]) -> str | None:
    """The id the API site renders ``found`` under, or None where it renders nothing."""
    try:
        target = found.final_target if isinstance(found, griffe.Alias) else found
    except (griffe.AliasResolutionError, griffe.CyclicAliasError):
        return None
    path = target.path
    parts = path.split(".")
    # a name of the package itself is on the top-level page, anything else on its stage's page
    page = parts[0] if len(parts) == 2 and not target.is_module else ".".join(parts[:2])
    if page not in roots:
        return None  # no API page renders it (the command line's modules)
    if any(part.startswith("_") and not part.startswith("__") for part in path.split(".")):
        return None  # a private module or name: not on the site
    node: Any = target
    while node is not None:
        if not node.is_module and not node.is_public:
            return None
        if node.is_module and node.parent is not None and not node.is_public:
            return None
        node = node.parent
    if not target.is_module and target.docstring is None:
        return None  # show_if_no_docstring is off
    return path


class SphinxRoles(griffe.Extension):
    """Rewrite Sphinx roles in every docstring into autorefs links (module docstring)."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:
        self.roots = _rendered_roots()
        for obj in self._walk(pkg):
            if obj.docstring is not None and ":" in obj.docstring.value:
                obj.docstring.value = ROLE.sub(
                    lambda m, obj=obj: self._link(m, obj, pkg), obj.docstring.value
                )

    def _walk(self, obj: griffe.Object):
        yield obj
        for member in obj.members.values():
            if not member.is_alias:
                yield from self._walk(member)

    def _link(self, match: re.Match[str], obj: griffe.Object, pkg: griffe.Module) -> str:
        role, text = match.groups()
        text = re.sub(r"\s+", "", text) if "<" not in text else " ".join(text.split())
        explicit = re.fullmatch(r"(.+?)\s*<([^>]+)>", text)
        if explicit:
            label, target = explicit.groups()
        else:
            target = text.lstrip("~!")
            label = target.rsplit(".", 1)[-1] if text.startswith("~") else target
        if role in CALLABLE_ROLES and not label.endswith(")"):
            label += "()"
        code = f"`{label}`"
        if hasattr(builtins, target):
            return code  # ValueError, KeyError: Python's own
        if not target.startswith(pkg.name) and "." in target and _lookup(pkg, target) is None:
            first = target.split(".", 1)[0]
            if first not in pkg.members and not any(
                _lookup(pkg, c) for c in _candidates(target, obj)
            ):
                return code  # another package's name (numpy, scipy, the standard library)
        for candidate in _candidates(target, obj):
            found = _lookup(pkg, candidate)
            if found is not None:
                path = _rendered(found, self.roots)
                return f"[{code}][{path}]" if path else code
        logger.warning(
            "%s: the %s role names '%s', which %s does not have", obj.path, role, target, pkg.name
        )
        return code
