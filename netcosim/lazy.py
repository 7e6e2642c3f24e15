"""Packages whose public names are imported on first use (PEP 562).

``__getattr__, __dir__ = lazy_exports(__name__, {"Name": "module", ...}, __all__)`` in a
package's ``__init__``: ``package.Name`` imports ``package.module`` the first time it is
asked for and keeps the value in the package's namespace, so importing the package
loads none of its modules (``import netcosim`` stays light; a process that needs only
the low-level controller of ``netcosim.controllers.landing`` loads neither SimPy nor CasADi).
"""

from __future__ import annotations

import sys
from importlib import import_module
from typing import Any, Callable, Iterable, Mapping

__all__ = ["lazy_exports"]


def lazy_exports(package: str, names: Mapping[str, str],
                 public: Iterable[str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The module-level ``__getattr__`` and ``__dir__`` of *package*: *names* maps each
    lazily imported name to the submodule (relative to *package*) that defines it;
    *public* is the package's ``__all__``."""
    public = list(public)

    def __getattr__(name: str) -> Any:
        module = names.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(import_module(f".{module}", package), name)
        sys.modules[package].__dict__[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(sys.modules[package].__dict__) | set(public))

    return __getattr__, __dir__
