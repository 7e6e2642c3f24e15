"""Invalid-input cases for ``tests/test_invalid_inputs.py``.

Each module in this package defines ``CASES``: a list of :class:`Case`.  A case calls
the public API (or the CLI) with one bad value and states the exception type it must
raise and a fragment of the message that names the bad value.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class Case:
    """One bad input: ``call()`` must raise ``exc`` with ``names`` in its message."""

    id: str
    call: Callable[[], object]
    exc: type[BaseException] | tuple[type[BaseException], ...]
    names: str
