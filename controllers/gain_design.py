"""Former module of the offline gain design; it lives in :mod:`controllers.planner.gain_design`.
Kept as an import path: everything public is re-exported."""

from .planner.gain_design import *  # noqa: F401,F403
from .planner.gain_design import __all__  # noqa: F401
from .planner import gain_design as _new


def __getattr__(name: str):
    """Names outside ``__all__`` (constants, helpers) are read from the new module."""
    return getattr(_new, name)
