"""mirl: learn how other robots behave — rewards, policies and faulty motion — from mostly
occluded observations (Bogert & Doshi, mIRL*/T+Int), and act on it."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("mirl")
except PackageNotFoundError:  # running from a source tree without installation
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
