"""The installed package's version, on the ground floor so every stage may ask for it."""

from __future__ import annotations

from functools import lru_cache

__all__ = ["package_version"]


@lru_cache(maxsize=1)
def package_version() -> str:
    """mirl's version from the installed distribution's metadata (``0.0.0+unknown`` when run
    from a source tree that was never installed). Read on first use: importlib.metadata costs
    20-80 ms, which ``mirl run`` need not pay."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("mirl")
    except PackageNotFoundError:
        return "0.0.0+unknown"
