"""A sweep on disk: a directory of Parquet files written as runs finish, safe to kill.

Layout of a sweep directory::

    sweep.json                  what the sweep is (see :func:`metadata`)
    parts/run-CCCCCC-SSSSSS.parquet
                                one row per finished run (case C, seed index S): the
                                journal; a run is finished exactly when its file exists
    tables/NAME/run-CCCCCC-SSSSSS.parquet
                                the run's table NAME, long format, the parameters,
                                seed_index and seed prepended
    runs.parquet                all runs in grid order, written when the sweep ends

Every file is written to a temporary name starting with ``.`` in the same directory and
then renamed (:func:`os.replace`, atomic on POSIX and Windows), and a run's tables are
written before its row: a sweep killed at any instant (even with SIGKILL) leaves only
complete files, loses no finished run, and at worst leaves a temporary file, which
readers skip (``pyarrow`` ignores names starting with ``.`` or ``_``) and the next sweep
into the directory deletes.
"""

from __future__ import annotations

import json
import os
import shutil
import uuid
import warnings
from pathlib import Path
from typing import Any

from ..errors import ConfigurationError

__all__ = ["Store", "METADATA", "FORMAT", "COMPARED"]

METADATA = "sweep.json"
#: Version of the directory layout.
FORMAT = 1
#: Metadata fields that must match for a sweep to continue in a directory.
COMPARED = ("scenario", "scenario_sha256", "params", "cases", "seeds", "root_seed", "netcosim_version")


def _atomic_write(path: Path, write) -> None:
    tmp = path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _write_frame(path: Path, frame) -> None:
    _atomic_write(path, lambda p: frame.to_parquet(p, index=False))


def _describe(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 120 else text[:117] + "..."


class Store:
    """The directory *root* of one sweep (created if missing)."""

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)
        self.parts = self.root / "parts"
        self.tables = self.root / "tables"

    # --- metadata -----------------------------------------------------------------
    def read_metadata(self) -> dict[str, Any] | None:
        """The stored metadata, or None if the directory holds no sweep."""
        path = self.root / METADATA
        if not path.is_file():
            return None
        try:
            return json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise ConfigurationError(f"cannot read the sweep metadata {str(path)!r}: {exc}") from None

    def check(self, meta: dict[str, Any], fresh: bool) -> None:
        """Refuse a directory the sweep *meta* cannot use, changing nothing: a file, a
        non-empty directory without metadata, or (unless *fresh*) another sweep, naming
        what differs."""
        if self.root.exists() and not self.root.is_dir():
            raise ConfigurationError(f"sweep output {str(self.root)!r} is a file, not a directory")
        old = self.read_metadata()
        if old is None and self.root.is_dir() and any(self.root.iterdir()):
            raise ConfigurationError(f"sweep output directory {str(self.root)!r} is not empty and holds no "
                                     f"{METADATA}: choose a new or an empty directory")
        if old is not None:
            differ = [k for k in COMPARED if old.get(k) != meta.get(k)]
            if differ and not fresh:
                k = differ[0]
                raise ConfigurationError(
                    f"sweep output directory {str(self.root)!r} holds a different sweep: {k} differs "
                    f"(stored {_describe(old.get(k))}, now {_describe(meta.get(k))})"
                    + (f"; also {', '.join(differ[1:])}" if differ[1:] else "")
                    + "; pass fresh=True (--fresh) to discard it, or choose another directory")

    def open(self, meta: dict[str, Any], fresh: bool) -> set[tuple[int, int]]:
        """Prepare the directory for the sweep *meta* (:meth:`check` first); returns the
        ``(case, seed_index)`` of the runs already finished there.  With *fresh* the
        sweep found there is deleted first."""
        self.check(meta, fresh)
        if fresh and self.read_metadata() is not None:
            self.clear()
        self.root.mkdir(parents=True, exist_ok=True)
        self.parts.mkdir(exist_ok=True)
        self.tables.mkdir(exist_ok=True)
        for tmp in list(self.root.rglob(".*.tmp")):
            tmp.unlink(missing_ok=True)
        _atomic_write(self.root / METADATA, lambda p: p.write_text(json.dumps(meta, indent=1) + "\n"))
        return self.finished()

    def clear(self) -> None:
        """Delete the sweep's files (and nothing else) from the directory."""
        for name in ("parts", "tables"):
            shutil.rmtree(self.root / name, ignore_errors=True)
        for name in (METADATA, "runs.parquet"):
            (self.root / name).unlink(missing_ok=True)

    # --- runs -----------------------------------------------------------------------
    @staticmethod
    def part_name(case: int, seed_index: int) -> str:
        """File name of run ``(case, seed_index)``."""
        return f"run-{case:06d}-{seed_index:06d}.parquet"

    def finished(self) -> set[tuple[int, int]]:
        """``(case, seed_index)`` of every run with a row on disk."""
        out = set()
        if self.parts.is_dir():
            for p in self.parts.glob("run-*.parquet"):
                _, c, s = p.stem.split("-")
                out.add((int(c), int(s)))
        return out

    def write_run(self, case: int, seed_index: int, record: dict[str, Any], tables: dict[str, Any]) -> None:
        """Store one finished run: its tables first, then its row (which marks it finished)."""
        import pandas as pd

        name = self.part_name(case, seed_index)
        for tname, frame in tables.items():
            directory = self.tables / tname
            directory.mkdir(exist_ok=True)
            _write_frame(directory / name, frame)
        _write_frame(self.parts / name, pd.DataFrame([record]))

    def read_run(self, case: int, seed_index: int) -> dict[str, Any]:
        """The stored row of run ``(case, seed_index)`` as a dict of Python scalars."""
        import pandas as pd

        frame = pd.read_parquet(self.parts / self.part_name(case, seed_index))
        row = frame.to_dict("records")[0]
        return {k: (None if v is None else v.item() if hasattr(v, "item") else v) for k, v in row.items()}

    def table_names(self) -> list[str]:
        """Names of the tables stored by any run."""
        if not self.tables.is_dir():
            return []
        return sorted(p.name for p in self.tables.iterdir() if p.is_dir())

    def read_table(self, name: str, case: int, seed_index: int):
        """Run ``(case, seed_index)``'s table *name*, or None if it returned none."""
        import pandas as pd

        path = self.tables / name / self.part_name(case, seed_index)
        return pd.read_parquet(path) if path.is_file() else None

    def write_runs(self, frame) -> None:
        """Write the whole run table to ``runs.parquet``.

        A metric whose runs returned values of different kinds (a number in one run, a
        string in another) cannot be one Parquet column: it is written as text, with a
        warning naming it (each run's own file keeps its value as returned)."""
        import pyarrow as pa

        try:
            _write_frame(self.root / "runs.parquet", frame)
        except (pa.ArrowInvalid, pa.ArrowTypeError):
            mixed = [c for c in frame.columns if frame[c].dtype == object
                     and len({type(v) for v in frame[c] if v is not None}) > 1]
            warnings.warn(f"sweep {str(self.root)!r}: metrics {mixed} hold values of different kinds; "
                          f"runs.parquet stores them as text", stacklevel=3)
            frame = frame.copy()
            for c in mixed:
                frame[c] = [None if v is None else str(v) for v in frame[c]]
            _write_frame(self.root / "runs.parquet", frame)
