"""Former module of the planner tasks; they live in :mod:`controllers.planner.tasks`.
Kept as an import path: everything public is re-exported."""

from .planner.tasks import *  # noqa: F401,F403
from .planner.tasks import __all__  # noqa: F401
from .planner import tasks as _new


def __getattr__(name: str):
    """Names outside ``__all__`` (constants, helpers) are read from the new module."""
    return getattr(_new, name)
