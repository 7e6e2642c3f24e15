"""Former home of :class:`BufferedFunction`; it lives in :mod:`plants.casadi_tools`,
the one CasADi evaluation/compile module of the project.  Kept as an import path."""

from .casadi_tools import BufferedFunction

__all__ = ["BufferedFunction"]
