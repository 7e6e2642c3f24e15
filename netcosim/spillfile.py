"""The temporary file a trace table's older encoded chunks move to (spilling), and its format.

:class:`~netcosim.columns.ColumnStore` holds a table's rows as encoded column chunks; when
they exceed the table's memory bound it hands runs of consecutive spillable chunks to
:meth:`SpillFile.write` and keeps only the reference returned.  A segment is written column
by column: each run of chunks whose columns have the same codecs and buffer types becomes
one chunk of all their rows, each column's buffers written one after the other as they are
(one ``os.writev`` call for up to 1024 of them), after a small pickled header (the rows and
layout of each such chunk).  No object graph is pickled: a write costs about one copy of its
bytes, into the operating system's page cache.  :meth:`SpillFile.read` gives the chunks back
(one array or ``bytes`` per column).  The format is private to this module.

Why not Arrow IPC or Parquet for the segments: the chunks are the store's own codecs (codes
into category tables kept in memory, type tags per row), which those formats would have to
re-encode at every spill and decode back; the raw buffers cost a copy and nothing else.
"""

from __future__ import annotations

import os
import pickle
import tempfile
from array import array
from operator import itemgetter
from typing import Any, Iterator

__all__ = ["SpillFile", "TAGGED"]

#: codecs of a type tag per row and the values (``(tags: bytes, values: array)``)
TAGGED = ("mixed", "fnone", "inone")

#: the most buffers one ``os.writev`` call takes
try:
    _IOV_MAX = max(1, min(os.sysconf("SC_IOV_MAX"), 1024))
except (AttributeError, ValueError, OSError):
    _IOV_MAX = 16


class SpillFile:
    """An unbuffered temporary file of spilled segments (deleted when closed or collected)."""

    __slots__ = ("_f",)

    def __init__(self):
        # unbuffered: the buffers are written as they are, straight from the arrays
        self._f = tempfile.TemporaryFile(prefix="netcosim-trace-", buffering=0)

    def write(self, groups: list[list], ncols: int) -> tuple[int, tuple]:
        """Append one segment holding *groups* (each ``[rows, (codecs, buffer types),
        [(n, columns), ...]]``: consecutive chunks of the same codecs and buffer types) and
        return ``(rows, ref)``; *ref* is ``(offset, length, codec sets per column, header
        length)``.  *ncols*: the number of columns of the rows."""
        f = self._f
        first, second = itemgetter(0), itemgetter(1)
        merged: list[tuple[int, tuple, list]] = []   # (rows, layout, [(n, columns), ...])
        for _, (codecs, types), chunks in groups:
            # the typecode of codes (2 or 4 bytes) and of mixed values (d or q) may differ
            # between chunks of the same codecs and types: split where it changes
            varying = [c for c, codec in enumerate(codecs)
                       if codec == "mixed" or (codec == "str" and types[c] is array)]
            for part in _runs(chunks, varying):
                layout = tuple([(codec, buffer_type(codec, v)) for codec, v in part[0][1]])
                merged.append((sum(n for n, _ in part), layout, part))
        shared: dict = {}         # one tuple per distinct layout: the header pickles it once
        header = pickle.dumps([(n, shared.setdefault(layout, layout)) for n, layout, _ in merged],
                              protocol=pickle.HIGHEST_PROTOCOL)
        offset = f.seek(0, 2)
        _write_all(f, header)
        for _, layout, part in merged:
            ns = [n for n, _ in part]
            colslist = [cols for _, cols in part]
            for c, (codec, typecode) in enumerate(layout):
                if codec == "none":
                    continue
                v = list(map(second, map(itemgetter(c), colslist)))   # the column's buffers
                if codec in TAGGED:
                    _write(f, list(map(first, v)), ns, 1)
                    v = list(map(second, v))
                _write(f, v, ns, array(typecode).itemsize if typecode else 1)
        n = sum(m[0] for m in merged)
        sig: list[set[str]] = [set() for _ in range(ncols)]  # codec names per column
        for layout in shared:
            for c, (codec, _) in enumerate(layout):
                sig[c].add(codec)
        return n, (offset, f.tell() - offset, tuple(frozenset(x) for x in sig), len(header))

    def read(self, ref) -> list[tuple[int, Any]]:
        """The chunks of the segment *ref* (each a run of the chunks spilled, as one chunk
        of all their rows)."""
        offset, _, _, header = ref
        f = self._f
        f.seek(offset)
        chunks: list[tuple[int, Any]] = []
        for n, layout in pickle.loads(_read(f, header)):
            cols: list = []
            for codec, typecode in layout:
                if codec == "none":
                    cols.append((codec, None))
                elif codec in TAGGED:
                    tags = _read(f, n)
                    vals = array(typecode)
                    vals.frombytes(_read(f, n * vals.itemsize))
                    cols.append((codec, (tags, vals)))
                elif typecode:
                    a = array(typecode)
                    a.frombytes(_read(f, n * a.itemsize))
                    cols.append((codec, a))
                else:
                    cols.append((codec, _read(f, n)))
            chunks.append((n, ("cols", cols)))
        return chunks

    def close(self) -> None:
        """Close (and so delete) the file."""
        self._f.close()

    @property
    def closed(self) -> bool:
        """Whether the file is closed (and deleted)."""
        return self._f.closed

    def fileno(self) -> int:
        """The file's descriptor (for ``os.fstat``)."""
        return self._f.fileno()


def buffer_type(codec: str, v) -> str:
    """The type of an encoded column's buffer *v* (encoded with *codec*): an array's typecode,
    ``""`` for bytes (or no buffer, codec ``none``); of the values for a tagged codec."""
    if codec in TAGGED:
        return v[1].typecode
    return v.typecode if type(v) is array else ""


def _runs(chunks: list, varying: list[int]) -> Iterator[list]:
    """*chunks* (``(n, columns)``) in runs whose columns *varying* have the same buffer types."""
    if not varying:
        yield chunks
        return
    run: list = []
    last = None
    for entry in chunks:
        cols = entry[1]
        key = tuple([buffer_type(*cols[c]) for c in varying])
        if run and key != last:
            yield run
            run = []
        run.append(entry)
        last = key
    if run:
        yield run


def _write(f, buffers: list, rows: list[int], itemsize: int) -> None:
    """Write *buffers* (bytes or arrays, of ``rows[i] * itemsize`` bytes each), one after the
    other, to the unbuffered file *f* at its position: gathered by ``os.writev`` where there
    is one, without copying them into one buffer first."""
    if not hasattr(os, "writev"):
        _write_all(f, b"".join(buffers))
        return
    fd = f.fileno()
    for i in range(0, len(buffers), _IOV_MAX):
        batch = buffers[i:i + _IOV_MAX]
        size = sum(rows[i:i + _IOV_MAX]) * itemsize
        done = os.writev(fd, batch)
        if done < size:   # a short write: the rest of the batch, in one piece
            _write_all(f, memoryview(b"".join(batch))[done:])


def _write_all(f, data) -> None:
    """Write all of *data* to the unbuffered file *f* (whose writes may be short)."""
    view = memoryview(data).cast("B")
    while view:
        view = view[f.write(view):]


def _read(f, n: int) -> bytes:
    """*n* bytes from the unbuffered file *f*."""
    data = f.read(n)
    while len(data) < n:
        more = f.read(n - len(data))
        if not more:
            raise EOFError(f"the trace's temporary file ends {n - len(data)} bytes early")
        data += more
    return data
