"""Former module of the sampled tracking planner (ch. 5); it lives in
:mod:`controllers.planner.sikm`.  Kept as an import path: everything public is re-exported."""

from .planner.sikm import *  # noqa: F401,F403
from .planner.sikm import __all__  # noqa: F401
from .planner import sikm as _new


def __getattr__(name: str):
    """Names outside ``__all__`` (constants, helpers) are read from the new module."""
    return getattr(_new, name)
