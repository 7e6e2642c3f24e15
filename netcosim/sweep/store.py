"""A sweep on disk: a directory of Parquet files written as runs finish, safe to kill,
checked against the SHA-256 of every file, owned by one sweep at a time.

Layout of a sweep directory::

    sweep.json                  what the sweep is (see :func:`metadata`)
    parts/run-CCCCCC-SSSSSS.parquet
                                one row per finished run (case C, seed index S): the
                                journal; a run is finished exactly when its file exists
    tables/NAME/run-CCCCCC-SSSSSS.parquet
                                the run's table NAME, long format, the parameters,
                                seed_index and seed prepended
    runs.parquet                all runs in grid order, written when the sweep ends
    digests.jsonl               the SHA-256 of every file above (one JSON line per run
                                written, and one per runs.parquet; the last line of a run wins)
    sweep.lock                  while a sweep writes into the directory: its pid and host

Every file is written to a temporary name starting with ``.`` in the same directory,
its SHA-256 computed and appended to ``digests.jsonl``, and then renamed
(:func:`os.replace`, atomic on POSIX and Windows); a run's tables are renamed before its
row.  A sweep killed at any instant (even with SIGKILL) therefore leaves only complete
files, each with its digest recorded, loses no finished run, and at worst leaves a
temporary file, which readers skip (``pyarrow`` ignores names starting with ``.`` or
``_``) and the next sweep into the directory deletes.  :meth:`Store.verify` compares
every finished run's files with their recorded digests: a bit flip, a truncated or a
deleted file is found and named with the run(s) it holds.

The lock (:class:`Lock`) keeps two sweeps out of one directory: ``sweep.lock`` is
created with ``O_EXCL`` and holds the owner's pid and host; a lock whose process is
gone (on this host) is taken over, and the lock is removed when the sweep ends, also on
an error or Ctrl-C.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import socket
import time
import uuid
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ConfigurationError, NetcosimError

__all__ = ["Store", "Lock", "Damage", "DamagedSweepError", "SweepLockedError", "METADATA", "DIGESTS", "LOCK",
           "FORMAT", "COMPARED", "param_dtypes", "file_sha256"]

METADATA = "sweep.json"
#: The digest journal: the SHA-256 of every file of the sweep.
DIGESTS = "digests.jsonl"
#: The lock file of the sweep writing into the directory.
LOCK = "sweep.lock"
_GUARD = "sweep.lock.takeover"
#: Version of the directory layout (2: with ``digests.jsonl``).
FORMAT = 2
#: Metadata fields that must match for a sweep to continue in a directory.
COMPARED = ("scenario", "scenario_sha256", "params", "cases", "seeds", "root_seed", "netcosim_version")
_HOUSEKEEPING = (LOCK, _GUARD)


def file_sha256(path: Path) -> str:
    """SHA-256 (hex) of the bytes of file *path*."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _describe(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 120 else text[:117] + "..."


# --- errors -------------------------------------------------------------------------
@dataclass(frozen=True)
class Damage:
    """A damaged file of a sweep: ``file`` (path relative to the sweep directory),
    ``reason`` and ``keys``, the ``(case, seed_index)`` of the runs it holds."""

    file: str
    reason: str
    keys: tuple[tuple[int, int], ...] = field(default=())


def describe_key(meta: dict[str, Any] | None, key: tuple[int, int]) -> str:
    """``case 1 {"a": 1} seed_index 0``: the run *key* ``(case, seed_index)`` named by its case's
    parameters, read from the sweep metadata *meta* (without it, or its ``cases``: by index)."""
    c, s = key
    cases = (meta or {}).get("cases") or []
    params = f" {json.dumps(cases[c], sort_keys=True)}" if 0 <= c < len(cases) else ""
    return f"case {c}{params} seed_index {s}"


def describe_damage(meta: dict[str, Any] | None, damage: list[Damage], limit: int = 20) -> list[str]:
    """One line per damaged file of *damage* (:class:`Damage`), at most *limit* then a count: the
    file, why, and the runs it holds (named by *meta*'s ``cases``, see :func:`describe_key`)."""
    lines = []
    for d in damage[:limit]:
        if len(d.keys) == 1:
            runs = f"run {describe_key(meta, d.keys[0])}"
        elif d.keys:
            runs = f"{len(d.keys)} runs (all runs: it is rebuilt from parts/)"
        else:
            runs = "no run"
        lines.append(f"{d.file}: {d.reason}; holds {runs}")
    if len(damage) > limit:
        lines.append(f"... and {len(damage) - limit} more damaged files")
    return lines


class DamagedSweepError(NetcosimError, OSError):
    """Files of a sweep directory do not match their recorded SHA-256 (a flipped bit, a
    truncated or deleted file) or cannot be read.  ``damage``: the :class:`Damage` of
    each file; ``keys``: the ``(case, seed_index)`` of the runs they hold (``--resume``
    or running the sweep again re-runs exactly those).  ``root``: the sweep directory;
    ``meta``: its metadata, whose ``cases`` name the runs in the message (None: by index)."""

    def __init__(self, root: Path, damage: list[Damage], meta: dict[str, Any] | None = None):
        self.root = root
        self.damage = list(damage)
        self.keys = sorted({k for d in damage for k in d.keys})
        lines = describe_damage(meta, self.damage)
        super().__init__(f"sweep {str(root)!r} is damaged: {len(self.damage)} file(s) do not match the SHA-256 "
                         f"recorded when they were written or cannot be read:\n  " + "\n  ".join(lines)
                         + f"\nrunning the sweep again (netcosim sweep --resume {root}) re-runs the damaged "
                           f"runs; load_sweep(..., verify=False) reads it as it is")


class SweepLockedError(ConfigurationError):
    """Another sweep is writing into the directory (the message names its pid and host)."""


# --- the lock -----------------------------------------------------------------------
def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:          # alive, another user's
        return True
    except OSError:
        return True
    return True


class Lock:
    """The advisory lock of sweep directory *root*: ``root/sweep.lock``, created with
    ``O_EXCL``, holding ``{"pid", "host", "token", "since"}``."""

    def __init__(self, root: Path):
        self.root = Path(root)
        self.path = self.root / LOCK
        self.token = uuid.uuid4().hex
        self.held = False

    def owner(self) -> dict[str, Any] | None:
        """The lock's content, None if there is no lock (``{}`` if it cannot be read)."""
        try:
            text = self.path.read_text()
        except FileNotFoundError:
            return None
        except OSError:
            return {}
        try:
            info = json.loads(text)
            return info if isinstance(info, dict) else {}
        except ValueError:
            return {}

    def _stale(self, info: dict[str, Any]) -> bool:
        pid = info.get("pid")
        return info.get("host") == socket.gethostname() and isinstance(pid, int) and not _pid_alive(pid)

    def _refuse(self, info: dict[str, Any]) -> SweepLockedError:
        if not info:
            who = "a process whose lock file cannot be read"
        else:
            who = f"process {info.get('pid')} on host {info.get('host')!r}"
            if info.get("since"):
                who += f" (since {time.strftime('%Y-%m-%d %H:%M:%S', time.localtime(info['since']))})"
        return SweepLockedError(f"sweep directory {str(self.root)!r} is in use by another sweep: {who}; wait for it "
                                f"to end, or, if that process is gone, delete {str(self.path)!r}")

    def check(self) -> None:
        """Raise :class:`SweepLockedError` if a live sweep holds the directory (changes nothing)."""
        info = self.owner()
        if info is not None and not self._stale(info):
            raise self._refuse(info)

    def acquire(self) -> None:
        """Take the lock (the directory must exist); a stale lock of a dead process on
        this host is taken over; a live one raises :class:`SweepLockedError` naming it."""
        for _ in range(3):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                info = self.owner()
                if info is None:
                    continue                       # released meanwhile: try again
                if not self._stale(info):
                    raise self._refuse(info) from None
                self._take_over(info)
                continue
            try:                                   # one write: a reader sees the owner or an empty file
                os.write(fd, json.dumps({"pid": os.getpid(), "host": socket.gethostname(), "token": self.token,
                                         "since": time.time()}).encode())
            finally:
                os.close(fd)
            self.held = True
            return
        raise self._refuse(self.owner() or {})

    def _take_over(self, stale: dict[str, Any]) -> None:
        """Remove the stale lock *stale*, unless another process does so first: one
        process at a time holds ``sweep.lock.takeover`` (itself taken over if its
        process is gone) and removes the lock only if it still holds *stale*."""
        guard = self.root / _GUARD
        for _ in range(2):
            try:
                fd = os.open(guard, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                try:
                    pid = int(guard.read_text() or "0")
                except (OSError, ValueError):
                    pid = 0
                if pid and _pid_alive(pid):
                    raise SweepLockedError(f"sweep directory {str(self.root)!r}: process {pid} is taking over its "
                                           f"stale lock; try again") from None
                guard.unlink(missing_ok=True)
                continue
            try:
                os.write(fd, str(os.getpid()).encode())
                os.close(fd)
                if self.owner() == stale:
                    self.path.unlink(missing_ok=True)
            finally:
                guard.unlink(missing_ok=True)
            return

    def release(self) -> None:
        """Remove the lock if this object holds it."""
        if self.held:
            info = self.owner()
            if info is not None and info.get("token") == self.token:
                self.path.unlink(missing_ok=True)
            self.held = False


# --- column types -------------------------------------------------------------------
def param_dtypes(cases: list[dict[str, Any]]) -> dict[str, str]:
    """The column type of each parameter of *cases* (the grid's dicts of parameter name ->
    value, all with the same names) in every file of the sweep: ``float64`` if any
    value is a float (ints and floats mixed), ``int64`` / ``bool`` (``Int64`` /
    ``boolean``, pandas' nullable types, if a case has None), ``str``, or ``null`` (all None)."""
    out: dict[str, str] = {}
    for name in cases[0]:
        values = [c[name] for c in cases]
        present = [v for v in values if v is not None]
        missing = len(present) < len(values)
        if not present:
            out[name] = "null"
        elif all(type(v) is bool for v in present):
            out[name] = "boolean" if missing else "bool"
        elif all(type(v) is int for v in present):
            out[name] = "Int64" if missing else "int64"
        elif all(type(v) in (int, float) for v in present):
            out[name] = "float64"
        else:
            out[name] = "str"
    return out


def typed(frame, dtypes: dict[str, str] | None):
    """*frame* with its parameter columns of the types *dtypes* (:func:`param_dtypes`)."""
    if not dtypes:
        return frame
    frame = frame.copy()
    for col, dtype in dtypes.items():
        if col in frame.columns and dtype not in ("str", "null"):
            frame[col] = frame[col].astype(dtype)
    return frame


def _to_parquet(frame, path: Path, dtypes: dict[str, str] | None) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(typed(frame, dtypes), preserve_index=False)
    for col, dtype in (dtypes or {}).items():
        if dtype == "str" and col in table.column_names and table.schema.field(col).type != pa.string():
            i = table.column_names.index(col)
            table = table.set_column(i, pa.field(col, pa.string()), table.column(i).cast(pa.string()))
    pq.write_table(table, path)


def _tmp(path: Path) -> Path:
    return path.with_name(f".{path.name}.{uuid.uuid4().hex}.tmp")


class Store:
    """The directory *root* of one sweep (created if missing)."""

    def __init__(self, root: str | os.PathLike):
        self.root = Path(root)
        self.parts = self.root / "parts"
        self.tables = self.root / "tables"
        self.dtypes: dict[str, str] | None = None

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
        if old is None and self.root.is_dir() and any(p.name not in _HOUSEKEEPING for p in self.root.iterdir()):
            raise ConfigurationError(f"sweep output directory {str(self.root)!r} is not empty and holds no "
                                     f"{METADATA}: choose a new or an empty directory")
        if old is not None and not fresh and old.get("format", 1) != FORMAT:
            raise ConfigurationError(
                f"sweep output directory {str(self.root)!r} holds a sweep of format {old.get('format', 1)}, written "
                f"by an earlier netcosim without the SHA-256 of its files (this one writes format {FORMAT}): "
                f"load_sweep still reads it; pass fresh=True (--fresh) to run it again from the start, or choose "
                f"another directory")
        if old is not None:
            differ = [k for k in COMPARED if old.get(k) != meta.get(k)]
            if differ and not fresh:
                k = differ[0]
                if k == "scenario_sha256":
                    what = _code_change(old, meta)
                else:
                    what = f"{k} differs (stored {_describe(old.get(k))}, now {_describe(meta.get(k))})"
                raise ConfigurationError(
                    f"sweep output directory {str(self.root)!r} holds a different sweep: {what}"
                    + (f"; also {', '.join(differ[1:])}" if differ[1:] else "")
                    + "; pass fresh=True (--fresh) to discard it, or choose another directory")

    def open(self, meta: dict[str, Any], fresh: bool) -> set[tuple[int, int]]:
        """Prepare the directory for the sweep *meta* (:meth:`check` first); returns the
        ``(case, seed_index)`` of the runs already finished there.  With *fresh* the
        sweep found there is deleted first.  The caller holds the :class:`Lock`."""
        self.check(meta, fresh)
        if fresh and self.read_metadata() is not None:
            self.clear()
        self.root.mkdir(parents=True, exist_ok=True)
        self.parts.mkdir(exist_ok=True)
        self.tables.mkdir(exist_ok=True)
        for tmp in list(self.root.rglob(".*.tmp")):
            tmp.unlink(missing_ok=True)
        journal = self.root / DIGESTS
        if journal.is_file() and journal.stat().st_size:
            with open(journal, "rb+") as f:          # a line cut by a kill must not swallow the next one
                f.seek(-1, os.SEEK_END)
                if f.read(1) != b"\n":
                    f.write(b"\n")
        tmp = _tmp(self.root / METADATA)
        try:
            tmp.write_text(json.dumps(meta, indent=1) + "\n")
            os.replace(tmp, self.root / METADATA)
        finally:
            tmp.unlink(missing_ok=True)
        return self.finished()

    def clear(self) -> None:
        """Delete the sweep's files (and nothing else) from the directory."""
        for name in ("parts", "tables"):
            shutil.rmtree(self.root / name, ignore_errors=True)
        for name in (METADATA, "runs.parquet", DIGESTS):
            (self.root / name).unlink(missing_ok=True)

    # --- digests ------------------------------------------------------------------
    def _record(self, entry: dict[str, Any]) -> None:
        with open(self.root / DIGESTS, "a") as f:
            f.write(json.dumps(entry, separators=(",", ":")) + "\n")

    def digests(self) -> tuple[dict[tuple[int, int], dict[str, str]], dict[str, str]]:
        """The recorded digests: ``{(case, seed_index): {file: sha256}}`` (the last
        record of each run) and ``{file: sha256}`` of the files of no run (runs.parquet).
        An unreadable line is skipped (its run then counts as unrecorded)."""
        runs: dict[tuple[int, int], dict[str, str]] = {}
        files: dict[str, str] = {}
        try:
            text = (self.root / DIGESTS).read_text(errors="replace")
        except FileNotFoundError:
            return runs, files
        for line in text.splitlines():
            try:
                entry = json.loads(line)
                if "run" in entry:
                    c, s = entry["run"]
                    runs[(int(c), int(s))] = {str(k): str(v) for k, v in entry["files"].items()}
                else:
                    files[str(entry["file"])] = str(entry["sha256"])
            except (ValueError, TypeError, KeyError, AttributeError):
                continue
        return runs, files

    def verify(self) -> list[Damage]:
        """The damaged files of the finished runs (and of ``runs.parquet``): a file whose
        SHA-256 differs from the one recorded when it was written (a flipped bit, a
        truncation), a recorded file that is missing, a file of a run with no digest.
        An empty list: every file is intact.  A directory written before digests were
        recorded (format 1) is not checked."""
        meta = self.read_metadata()
        if meta is None or int(meta.get("format", 1)) < 2:
            return []
        runs, files = self.digests()
        finished = sorted(self.finished())
        tables = self.table_names()
        damage: list[Damage] = []
        for key in finished:
            name = self.part_name(*key)
            recorded = runs.get(key)
            on_disk = [f"parts/{name}"] + [f"tables/{t}/{name}" for t in tables
                                           if (self.tables / t / name).is_file()]
            if recorded is None:
                damage += [Damage(f, "no SHA-256 recorded for this run", (key,)) for f in on_disk]
                continue
            for f in on_disk:
                if f not in recorded:
                    damage.append(Damage(f, "not a file of this run as recorded", (key,)))
            for f, sha in recorded.items():
                path = self.root / f
                if not path.is_file():
                    damage.append(Damage(f, "missing", (key,)))
                elif file_sha256(path) != sha:
                    damage.append(Damage(f, "SHA-256 differs from the one recorded (damaged or truncated)", (key,)))
        runs_file = self.root / "runs.parquet"
        if runs_file.is_file():
            recorded_runs = files.get("runs.parquet")
            if recorded_runs is None or file_sha256(runs_file) != recorded_runs:
                reason = ("no SHA-256 recorded" if recorded_runs is None
                          else "SHA-256 differs from the one recorded (damaged or truncated)")
                damage.append(Damage("runs.parquet", reason, tuple(finished)))
        return damage

    def remove_run(self, case: int, seed_index: int) -> None:
        """Delete run ``(case, seed_index)``'s files: its row first (it is then not
        finished), then its tables."""
        name = self.part_name(case, seed_index)
        (self.parts / name).unlink(missing_ok=True)
        for t in self.table_names():
            (self.tables / t / name).unlink(missing_ok=True)

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
                parts = p.stem.split("-")
                if len(parts) == 3 and parts[1].isdigit() and parts[2].isdigit():
                    out.add((int(parts[1]), int(parts[2])))
        return out

    def write_run(self, case: int, seed_index: int, record: dict[str, Any], tables: dict[str, Any]) -> None:
        """Store one finished run, seed *seed_index* of case *case* (its run-table row *record*
        and its per-run *tables*, name -> DataFrame), replacing a previous version of it: each file to a
        temporary name, their digests to the journal, then the tables renamed, then the
        row (which marks the run finished)."""
        import pandas as pd

        name = self.part_name(case, seed_index)
        self.remove_run(case, seed_index)
        staged: list[tuple[Path, Path]] = []
        try:
            for tname, frame in tables.items():
                directory = self.tables / tname
                directory.mkdir(exist_ok=True)
                staged.append((_tmp(directory / name), directory / name))
                _to_parquet(frame, staged[-1][0], self.dtypes)
            staged.append((_tmp(self.parts / name), self.parts / name))
            _to_parquet(pd.DataFrame([record]), staged[-1][0], self.dtypes)
            self._record({"run": [case, seed_index],
                          "files": {str(final.relative_to(self.root).as_posix()): file_sha256(tmp)
                                    for tmp, final in staged}})
            for tmp, final in staged:
                os.replace(tmp, final)
        finally:
            for tmp, _ in staged:
                tmp.unlink(missing_ok=True)

    def read_run(self, case: int, seed_index: int) -> dict[str, Any]:
        """The stored row of run ``(case, seed_index)`` as a dict of Python scalars."""
        import pandas as pd

        frame = pd.read_parquet(self.parts / self.part_name(case, seed_index))
        row = frame.to_dict("records")[0]
        return {k: _scalar(v) for k, v in row.items()}

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
        """Write the whole run table *frame* to ``runs.parquet`` (its digest recorded first).

        A metric whose runs returned values of different kinds (a number in one run, a
        string in another) cannot be one Parquet column: it is written as text, with a
        warning naming it (each run's own file keeps its value as returned)."""
        import pyarrow as pa

        path = self.root / "runs.parquet"
        tmp = _tmp(path)
        try:
            try:
                _to_parquet(frame, tmp, self.dtypes)
            except (pa.ArrowInvalid, pa.ArrowTypeError):
                mixed = [c for c in frame.columns if frame[c].dtype == object
                         and len({type(v) for v in frame[c] if v is not None}) > 1]
                warnings.warn(f"sweep {str(self.root)!r}: metrics {mixed} hold values of different kinds; "
                              f"runs.parquet stores them as text", stacklevel=3)
                frame = frame.copy()
                for c in mixed:
                    frame[c] = [None if v is None else str(v) for v in frame[c]]
                _to_parquet(frame, tmp, self.dtypes)
            self._record({"file": "runs.parquet", "sha256": file_sha256(tmp)})
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)


def _scalar(v: Any) -> Any:
    import pandas as pd

    if v is None or v is pd.NA:
        return None
    return v.item() if hasattr(v, "item") else v


def _code_change(old: dict[str, Any], new: dict[str, Any]) -> str:
    """What changed in the scenario's code, from the per-definition digests."""
    where = new.get("scenario_file") or old.get("scenario_file") or new.get("scenario")
    before, after = old.get("scenario_code") or {}, new.get("scenario_code") or {}
    changed = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    detail = f" ({', '.join(changed[:8])}{', ...' if len(changed) > 8 else ''} changed)" if changed else ""
    return (f"the scenario's code changed: {where}{detail} (comments, docstrings and formatting do not count; "
            f"a run already stored may not be what the code computes now)")
