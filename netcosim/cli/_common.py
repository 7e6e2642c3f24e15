"""What every ``netcosim`` subcommand shares: :class:`UsageError` (exit status 2) and the checks of paths."""

from __future__ import annotations

import os
from pathlib import Path


class UsageError(Exception):
    """A command-line argument the command cannot use; the message names it (exit status 2)."""


def _syntax_error(exc: SyntaxError) -> UsageError:
    """One line naming the file and line of *exc* (``file.py:3: SyntaxError: invalid syntax``)."""
    return UsageError(f"{exc.filename or '<unknown file>'}:{exc.lineno}: {type(exc).__name__}: {exc.msg}")



def check_writable_dir(given: str | os.PathLike, what: str) -> Path:
    """*given* as a Path if it is, or could be made, a directory this process can write in.

    Nothing is created: the nearest existing ancestor must be a directory in which a
    (nameless, at once removed) temporary file can be made.  Raises :class:`UsageError`
    naming *what* and *given* otherwise.
    """
    import tempfile
    if not os.fspath(given).strip():
        raise UsageError(f"{what} must name a directory, got {os.fspath(given)!r}")
    path = Path(given)
    probe = path
    while not probe.exists() and probe.parent != probe:
        probe = probe.parent
    if not probe.is_dir():
        raise UsageError(f"{what} {os.fspath(given)!r} cannot be a directory: {str(probe)!r} is a file")
    try:
        tempfile.TemporaryFile(dir=probe).close()
    except OSError as exc:
        raise UsageError(f"{what} {os.fspath(given)!r} is not writable: cannot write in {str(probe)!r} "
                         f"({exc.strerror or exc})") from None
    return path


