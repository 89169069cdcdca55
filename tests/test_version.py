"""The package's version: the installed distribution's, read once."""

from __future__ import annotations

import importlib.metadata

from mirl._version import package_version


def test_the_version_is_the_installed_distributions():
    assert package_version() == importlib.metadata.version("mirl")


def test_it_is_read_once(monkeypatch):
    package_version.cache_clear()
    calls = []
    real = importlib.metadata.version
    monkeypatch.setattr(
        importlib.metadata, "version", lambda name: calls.append(name) or real(name)
    )
    first = package_version()
    assert package_version() is first and calls == ["mirl"]


def test_an_uninstalled_tree_says_so(monkeypatch):
    package_version.cache_clear()

    def missing(name):
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(importlib.metadata, "version", missing)
    try:
        assert package_version() == "0.0.0+unknown"
    finally:
        package_version.cache_clear()
