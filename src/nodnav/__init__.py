"""nodnav: opinion-driven multi-robot navigation through narrow corridors."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("nodnav")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0"
