"""Columnar row storage: the rows of a trace table in typed arrays, strings as small codes.

A :class:`ColumnStore` takes rows (tuples) one at a time and returns them unchanged,
but holds them compactly: appending is a plain list append, and :meth:`ColumnStore.maintain`
(called by the simulation every :data:`netcosim.sim.MAINTAIN_EVERY` events) encodes the
appended tuples ``chunk_rows`` at a time, column by column, keeping the newest as tuples:

===================  ==================================================================
column values        stored as
===================  ==================================================================
all ``float``        ``array('d')`` (8 bytes a row; every bit kept, NaN and -0.0 too)
all ``int``          ``array('q')`` (8 bytes a row) when they fit in 64 bits
all ``bool``         ``bytes`` (1 byte a row)
declared ``uint8``   ``bytes`` (1 byte a row): small codes such as the schedule's states
all ``str``          codes into the column's category table (``bytes`` or ``array`` of
                     1, 2 or 4 bytes a row); each distinct string is stored once per table
all ``None``         nothing but the row count
floats, ints, None   a type tag per row (1 byte) and the values as ``array('d')``
                     (codec ``fnone``; ints and None: ``inone``, ``array('q')``): read
                     back as one float column, None as NaN, as ``from_records`` makes it
numbers with bools   a type tag per row (1 byte) and the values as ``array('d')`` (or
                     ``array('q')`` without floats); integers beyond 2**53 among floats
                     make the column ``anything else``
anything else        a plain list of the objects (no tuple per row)
===================  ==================================================================

A row of the ``signals`` table (``time, source, signal, value``) takes about 20 bytes
encoded instead of about 150 as a tuple of Python objects.  Reading decodes the rows
back to the very same values (same types, same bits), so the DataFrames built from them
are identical.

With a ``memory`` budget, the encoded chunks beyond it move to an anonymous temporary
file (:meth:`ColumnStore._spill`): each run of consecutive chunks whose columns share
codecs and buffer types is written as one chunk of all their rows, column by column, the
arrays' own buffers gathered by ``os.writev`` behind a small pickled header (rows and
codecs of each merged chunk); reading one back makes one array (or ``bytes``) per column.
Cost on 10 periodic tasks over 100 s (1.17 million rows, five spills of 21 MB): about 18
ms, and 0.9 % more CPU for the whole run than without a budget (9 paired runs, median).

Why not pandas or pyarrow builders: the hot path appends one row at a time, where a
list append is the cheapest operation Python has; both libraries build columns from
whole batches, which is what the chunks are, but would be imported by every simulation
(the standard library's :mod:`array` costs nothing to import).
"""

from __future__ import annotations

from array import array
from operator import itemgetter
from typing import Any, Callable, Iterable, Iterator, Sequence

from .packing import INT64 as _Q
from .packing import PackError, typed_array
from .readback import categorical_from_codes
from .spillfile import TAGGED as _TAGGED
from .spillfile import SpillFile

__all__ = ["ColumnStore", "CHUNK_ROWS"]

#: Rows encoded together; at most twice as many rows are held as tuples at any time.  Small
#: chunks are encoded while their tuples are still in the CPU cache (1024 cost about 0.4 µs
#: more per kernel job) and keep fewer tuples alive.
CHUNK_ROWS = 256

_NONE = type(None)
#: type tags of the ``mixed`` codec (numbers and None in one column)
_TAGS = {float: 0, int: 1, bool: 2, _NONE: 3}
_UNTAG = (float, int, bool, lambda v: None)
_EXACT = 2 ** 53  # integers a double holds exactly
#: codecs a column of numbers and None may mix and still be read as one float column
_NUMERIC = frozenset({"d", "q", "fnone", "inone", "none"})


def _code_type(n: int) -> str:
    return "H" if n <= 0xFFFF else "I"


class ColumnStore:
    """Rows of *ncols* columns, held as typed column chunks plus a tail of recent tuples.

    Behaves like the list of rows appended (``len``, iteration, indexing, ``clear``);
    ``append`` and ``extend`` are the bound methods of a list (the cheapest call Python
    has); :meth:`maintain` encodes what they appended.
    Rows must be tuples of *ncols* values; a chunk whose rows do not all have *ncols*
    values is kept as rows.  The columns whose indices are in *categorical* are coded
    whatever their type, without checking it (the hot path's names): values equal as
    dictionary keys share a code and read back as the first of them seen (``1``,
    ``1.0`` and ``True`` would; names never are).  Other columns are coded as strings
    only when every value of the chunk is a ``str``.

    *dtypes* (one per column: ``None``, ``"int"``, ``"float"``, ``"bool"`` or ``"uint8"``,
    integers 0..255 stored one byte each) is the
    producer's promise about a column's values, for the hot-path tables whose producers
    are known: the column is stored as declared without checking every value's type (a
    value that cannot be stored so, e.g. None, makes the chunk's column checked as
    usual; one that can, e.g. an ``int`` in a ``"float"`` column, reads back as the
    declared type).  ``None``: the type is found from the values.

    *chunk_rows*: the rows per encoded chunk (default :data:`CHUNK_ROWS`); *memory*: the
    bytes of encoded chunks held in memory before the older ones move to a temporary file
    (None, default: no limit).
    """

    __slots__ = ("append", "extend", "ncols", "chunk_rows", "categorical", "dtypes", "memory", "spills",
                 "_tail", "_chunks", "_n", "_codes", "_names", "_bytes", "_limit", "_file", "_spilled")

    def __init__(self, ncols: int, chunk_rows: int = CHUNK_ROWS, categorical: Iterable[int] = (),
                 dtypes: Sequence[str | None] | None = None, memory: int | None = None):
        self.ncols = ncols
        self.chunk_rows = chunk_rows
        self.categorical = frozenset(categorical)
        self.dtypes = tuple(dtypes) if dtypes is not None else (None,) * ncols
        if len(self.dtypes) != ncols or not set(self.dtypes) <= {None, "int", "float", "bool", "uint8"}:
            raise ValueError(f"dtypes must be {ncols} of None, 'int', 'float', 'bool', 'uint8'; got {dtypes!r}")
        self._tail: list[tuple] = []
        #: encoded chunks: (number of rows, list of encoded columns) or (n, list of rows)
        self._chunks: list[tuple[int, Any]] = []
        self._n = 0                                   # rows in chunks
        self._codes: list[dict[str, int]] = [{} for _ in range(ncols)]   # per column: string -> code
        self._names: list[list[str]] = [[] for _ in range(ncols)]        # per column: code -> string
        #: bytes of encoded chunks held in memory before the older ones move to a temporary
        #: file (:meth:`_spill`); None: no limit
        self.memory = memory
        #: how many times chunks were moved to the file
        self.spills = 0
        self._bytes = 0                               # encoded bytes of the chunks in memory
        self._limit = memory                          # spill when _bytes exceeds it
        self._file: Any = None                        # the temporary file, once something is spilled
        self._spilled = 0                             # rows in the file
        # the hot path: C-level list methods; encoding waits for maintain()
        self.append = self._tail.append
        self.extend = self._tail.extend

    def maintain(self, more: Callable[[], bool] | None = None) -> bool:
        """Encode the tuples appended so far, ``chunk_rows`` at a time, until fewer than
        ``2 * chunk_rows`` are left (the newest stay tuples, for :meth:`replace`).

        ``more()``, when given, is asked before each chunk after the first; encoding
        stops when it returns False (a real-time caller's time budget).  Returns True
        when nothing is left to encode."""
        k2 = 2 * self.chunk_rows
        first = True
        while len(self._tail) >= k2:
            if not first and more is not None and not more():
                return False
            self._compact()
            first = False
        return True

    # -- encoding ------------------------------------------------------------------
    def _compact(self) -> None:
        """Encode the oldest ``chunk_rows`` tuples of the tail as one chunk."""
        k = self.chunk_rows
        rows = self._tail[:k]
        del self._tail[:k]
        chunk = self._encode(rows)
        self._chunks.append((k, chunk))
        self._n += k
        if self._limit is not None:
            self._bytes += _chunk_bytes(chunk)
            if self._bytes > self._limit:
                self._spill()

    # -- spilling --------------------------------------------------------------------
    def _spill(self) -> None:
        """Move the encoded chunks held in memory, but the newest (:meth:`replace` may
        still change it), to the temporary file, as segments of consecutive chunks.

        A chunk of plain values (numbers, None, coded strings) is spilled; one holding
        arbitrary objects (``obj`` columns, ``rows`` chunks) stays in memory, so that
        every value read back is the very object appended.  The category tables stay in
        memory: a code read back from the file names the same object.  Runs of chunks of
        the same codecs and buffer types go to the file as one segment
        (:class:`~netcosim.spillfile.SpillFile`: raw column buffers, nothing pickled but
        a small header)."""
        if self._file is None:
            self._file = SpillFile()
        first, second = itemgetter(0), itemgetter(1)
        out: list = []
        #: the run of spillable chunks gathered: [rows, (codecs, buffer types), [(n, columns), ...]]
        groups: list[list] = []

        def write_run():
            if groups:
                n, ref = self._file.write(groups, self.ncols)
                out.append((n, ("spill", ref)))
                self._spilled += n
                groups.clear()
        for entry in self._chunks[:-1]:
            n, (kind, data) = entry
            if kind == "cols":
                codecs = tuple(map(first, data))
                if "obj" not in codecs:
                    key = (codecs, tuple(map(type, map(second, data))))
                    if groups and groups[-1][1] == key:
                        g = groups[-1]
                        g[0] += n
                        g[2].append((n, data))
                    else:
                        groups.append([n, key, [(n, data)]])
                    continue
            write_run()
            out.append(entry)
        write_run()
        out.append(self._chunks[-1])
        self._chunks[:] = out
        self._bytes = sum(_chunk_bytes(ch) for _, ch in out)
        self._limit = self._bytes + self.memory if self.memory is not None else None
        self.spills += 1

    def _load(self, ref) -> list[tuple[int, Any]]:
        """The chunks of the spilled segment *ref* (:meth:`SpillFile.read
        <netcosim.spillfile.SpillFile.read>`)."""
        return self._file.read(ref)

    def _chunks_in_order(self) -> Iterator[tuple[int, Any]]:
        """Every encoded chunk, oldest first, spilled segments loaded one at a time (a
        spilled chunk may hold any number of rows)."""
        for n, chunk in self._chunks:
            if chunk[0] == "spill":
                yield from self._load(chunk[1])
            else:
                yield n, chunk

    @property
    def spilled_rows(self) -> int:
        """Rows held in the temporary file."""
        return self._spilled

    def _encode(self, rows: list[tuple]):
        try:
            transposed = list(zip(*rows, strict=True))  # raises when the rows differ in length
        except ValueError:
            return ("rows", rows)
        if len(transposed) != self.ncols:
            return ("rows", rows)
        cols: list = []
        categorical, dtypes = self.categorical, self.dtypes
        for c, col in enumerate(transposed):
            if c in categorical:
                try:
                    cols.append(("str", self._code(c, col)))
                    continue
                except TypeError:  # an unhashable value: stored by type below
                    pass
            declared = dtypes[c]
            if declared is not None:
                try:  # the producer's promise: no type check (a value that does not fit raises)
                    if declared == "int":
                        cols.append(("q", typed_array(_Q, col)))
                    elif declared == "float":
                        cols.append(("d", typed_array("d", col)))
                    elif declared == "uint8":
                        cols.append(("u8", bytes(col)))
                    else:
                        cols.append(("bool", bytes(col)))
                    continue
                except (TypeError, ValueError, OverflowError, PackError):  # e.g. None in an int column
                    pass
            types = set(map(type, col))
            t = types.pop() if len(types) == 1 else None
            if t is float:
                cols.append(("d", typed_array("d", col)))
            elif t is int:
                try:
                    cols.append(("q", typed_array(_Q, col)))
                except PackError:
                    cols.append(("obj", list(col)))
            elif t is bool:
                cols.append(("bool", bytes(col)))
            elif t is str:
                cols.append(("str", self._code(c, col)))
            elif t is _NONE:
                cols.append(("none", None))
            else:
                cols.append(self._mixed(col, types) if t is None and types <= _TAGS.keys()
                            else ("obj", list(col)))
        return ("cols", cols)

    def _code(self, c: int, col):
        """Codes of the values *col* in column *c*'s category table (new values get the next
        codes, in order of appearance)."""
        codes, names = self._codes[c], self._names[c]
        try:
            coded = list(map(codes.__getitem__, col))
        except KeyError:
            for s in dict.fromkeys(col):
                if s not in codes:
                    codes[s] = len(names)
                    names.append(s)
            coded = list(map(codes.__getitem__, col))
        return bytes(coded) if len(names) <= 0x100 else array(_code_type(len(names) - 1), coded)

    @staticmethod
    def _mixed(col, types):
        """Numbers of several types and None: a type tag per row and the values as doubles (or
        64-bit integers when there is no float); ``obj`` when an integer would not be exact."""
        tags = bytes(map(_TAGS.__getitem__, map(type, col)))
        vals = [0 if v is None else v for v in col] if _NONE in types else col
        try:
            if float in types:
                if int in types and not all(-_EXACT <= v <= _EXACT for v in col if type(v) is int):
                    return ("obj", list(col))
                # without bools (e.g. a frame's bits and backoff): read back as one float column
                return ("fnone" if bool not in types else "mixed", (tags, array("d", vals)))
            return ("inone" if bool not in types else "mixed", (tags, array(_Q, vals)))
        except OverflowError:
            return ("obj", list(col))

    def _decode(self, n: int, chunk) -> list[tuple]:
        kind, data = chunk
        if kind == "rows":
            return data
        cols = []
        for c, (codec, v) in enumerate(data):
            if codec == "d" or codec == "q":
                cols.append(v.tolist())
            elif codec == "str":
                cols.append(list(map(self._names[c].__getitem__, v)))
            elif codec == "u8":
                cols.append(list(v))
            elif codec == "bool":
                cols.append([b != 0 for b in v])
            elif codec == "none":
                cols.append([None] * n)
            elif codec in _TAGGED:
                tags, vals = v
                cols.append([_UNTAG[t](x) for t, x in zip(tags, vals.tolist())])
            else:
                cols.append(v)
        return list(zip(*cols))

    # -- the list protocol ---------------------------------------------------------
    def __len__(self) -> int:
        return self._n + len(self._tail)

    def __iter__(self) -> Iterator[tuple]:
        k = self.chunk_rows
        for n, chunk in self._chunks_in_order():
            if n <= k:
                yield from self._decode(n, chunk)
            else:   # a spilled run of chunks: decoded a chunk's rows at a time
                for a in range(0, n, k):
                    b = min(a + k, n)
                    yield from self._decode(b - a, _piece(chunk, a, b))
        yield from list(self._tail)

    def __getitem__(self, i: int) -> tuple:
        n = len(self)
        if not isinstance(i, int):
            raise TypeError(f"row index must be an integer, got {i!r}")
        if i < 0:
            i += n
        if not 0 <= i < n:
            raise IndexError(f"row {i} out of range ({n} rows)")
        if i >= self._n:
            return self._tail[i - self._n]
        for k, chunk in self._chunks:
            if i < k:
                if chunk[0] == "spill":
                    for k2, c2 in self._load(chunk[1]):
                        if i < k2:
                            return self._decode(1, _piece(c2, i, i + 1))[0]
                        i -= k2
                return self._decode(k, chunk)[i]
            i -= k
        raise AssertionError("unreachable")

    def clear(self) -> None:
        """Drop every row (the category tables stay: codes remain valid; the temporary file
        is deleted)."""
        self._tail.clear()
        self._chunks.clear()
        self._n = 0
        self._bytes, self._limit, self._spilled = 0, self.memory, 0
        if self._file is not None:
            self._file.close()
            self._file = None

    def replace(self, old: tuple, new: tuple) -> bool:
        """Overwrite row *old* with *new*; False when *old* is not held.

        *old* is looked up by identity among the tuples of the tail, then by value in
        the newest encoded chunk (its tuple no longer exists once encoded).
        """
        tail = self._tail
        for i in range(len(tail) - 1, -1, -1):
            if tail[i] is old:
                tail[i] = new
                return True
        if self._chunks and self._chunks[-1][1][0] != "spill":
            n, chunk = self._chunks[-1]
            rows = self._decode(n, chunk)
            for i in range(n - 1, -1, -1):
                if rows[i] == old:
                    rows[i] = new
                    new_chunk = self._encode(rows)
                    if self._limit is not None:
                        self._bytes += _chunk_bytes(new_chunk) - _chunk_bytes(chunk)
                    self._chunks[-1] = (n, new_chunk)
                    return True
        return False

    def __repr__(self) -> str:
        return (f"<ColumnStore {len(self)} rows: {self._n} encoded ({self._spilled} in a file), "
                f"{len(self._tail)} as tuples>")

    # -- reading as columns ----------------------------------------------------------
    def frame(self, columns: Sequence[str], extra: Sequence[tuple] = (), categories: Iterable[int] = (),
              identity: Iterable[int] = ()):
        """The rows, followed by *extra*, as ``pandas.DataFrame.from_records(rows, columns=columns)``
        would build them, but column by column from the encoded chunks (spilled segments
        loaded one at a time): no tuple per row is made, so reading a long table needs
        about the memory of the DataFrame itself.

        Numeric columns stored in one codec (all ``float``, all ``int``, all ``bool``)
        become numpy arrays directly; every other column is gathered as an object array
        and converted by the very function ``from_records`` uses, so the frame is the same
        value for value and dtype for dtype.

        The columns whose indices are in *categories* and whose values are all strings
        come back instead as what ``.astype("category")`` would make of that column
        (categories sorted, only those used), built from the codes without a string per
        row.  The coded columns whose indices are in *identity* (objects coded by
        identity, e.g. the kernel's task objects) come back as a pandas ``Categorical``
        of those objects (categories in order of first appearance, only those used)."""
        import numpy as np
        import pandas as pd
        from pandas.core.internals.construction import convert_object_array

        rest = list(self._tail) + list(extra)
        last: list = []
        if rest:
            enc = self._encode(rest)
            last = [(len(rest), enc)] if enc[0] == "cols" else [(len(rest), ("rows", rest))]
        entries = self._chunks + last
        total = sum(n for n, _ in entries)
        ncols = self.ncols
        if len(columns) != ncols:
            raise ValueError(f"{len(columns)} column names for {ncols} columns")
        # codecs of each column over every chunk
        sig: list[set] = [set() for _ in range(ncols)]
        for _, chunk in entries:
            kind, data = chunk
            if kind == "spill":
                for c, s in enumerate(data[2]):
                    sig[c] |= s
            elif kind == "cols":
                for c, (codec, _) in enumerate(data):
                    sig[c].add(codec)
            else:
                for s in sig:
                    s.add("rows")
        fast = {"d": np.float64, "q": np.int64, "bool": np.bool_, "u8": np.int64, "str": np.int32}
        out: list = []
        for c in range(ncols):
            codecs = sig[c]
            # one codec: its numpy type (coded strings: their codes, turned into values at the end)
            dtype = fast[next(iter(codecs))] if len(codecs) == 1 and next(iter(codecs)) in fast else object
            if codecs == {"str"}:   # the category table is complete: the smallest code type
                dtype = _small_int(len(self._names[c]))
            elif codecs <= _NUMERIC and (len(codecs) > 1 or codecs <= {"fnone", "inone"}):
                dtype = np.float64   # numbers (and None): from_records makes floats (and None NaN)
            out.append(np.empty(total, dtype=dtype))
        coded = [sig[c] == {"str"} for c in range(ncols)]
        as_category = frozenset(categories)
        by_identity = frozenset(identity)
        names_arr: list = [None] * ncols

        def names(c):
            if names_arr[c] is None or len(names_arr[c]) != len(self._names[c]):
                a = np.empty(len(self._names[c]), dtype=object)
                for i, v in enumerate(self._names[c]):
                    a[i] = v
                names_arr[c] = a
            return names_arr[c]

        def chunks():
            for n, chunk in entries:
                if chunk[0] == "spill":
                    yield from self._load(chunk[1])
                else:
                    yield n, chunk
        pos = 0
        for n, chunk in chunks():
            kind, data = chunk
            sl = slice(pos, pos + n)
            if kind != "cols":
                rows = self._decode(n, chunk)
                for c in range(ncols):
                    col = out[c]
                    for i, r in enumerate(rows):
                        col[pos + i] = r[c]
            else:
                for c, (codec, v) in enumerate(data):
                    col = out[c]
                    if (codec == "fnone" or codec == "inone") and col.dtype != object:
                        tags, vals = v
                        col[sl] = np.frombuffer(vals, dtype=np.float64 if codec == "fnone" else np.int64)
                        col[sl][np.frombuffer(tags, dtype=np.uint8) == _TAGS[_NONE]] = np.nan
                    elif codec == "none" and col.dtype != object:
                        col[sl] = np.nan
                    elif codec in ("d", "q"):
                        col[sl] = np.frombuffer(v, dtype=np.float64 if codec == "d" else np.int64) \
                            if col.dtype != object else v.tolist()
                    elif codec in ("u8", "bool"):
                        raw = np.frombuffer(v, dtype=np.uint8)
                        if col.dtype != object:
                            col[sl] = raw
                        else:
                            col[sl] = self._decode_column(n, codec, v, c)
                    elif codec == "str":
                        codes = np.frombuffer(v, dtype=np.uint8) if isinstance(v, bytes) \
                            else np.frombuffer(v, dtype=np.dtype(v.typecode))
                        col[sl] = codes if coded[c] else names(c)[codes]
                    else:
                        vals = self._decode_column(n, codec, v, c)
                        tmp = np.empty(n, dtype=object)
                        for i, x in enumerate(vals):
                            tmp[i] = x
                        col[sl] = tmp
            pos += n
        # object columns as from_records converts them, one at a time (one temporary object array)
        for c in range(ncols):
            if coded[c] and (c in as_category or c in by_identity):
                cat = categorical_from_codes(out[c], names(c), objects=c in by_identity)
                if cat is not None:
                    out[c] = cat
                    continue
            if coded[c]:
                obj = names(c)[out[c]]
                out[c] = None
                out[c] = convert_object_array([obj], dtype=None)[0]
                del obj
            elif out[c].dtype == object:
                out[c] = convert_object_array([out[c]], dtype=None)[0]
        return pd.DataFrame(dict(zip(columns, out)), columns=list(columns), copy=False)

    def _decode_column(self, n: int, codec: str, v, c: int) -> list:
        """One encoded column of a chunk as the list of its values."""
        if codec == "d" or codec == "q":
            return v.tolist()
        if codec == "str":
            return list(map(self._names[c].__getitem__, v))
        if codec == "u8":
            return list(v)
        if codec == "bool":
            return [b != 0 for b in v]
        if codec == "none":
            return [None] * n
        if codec in _TAGGED:
            tags, vals = v
            return [_UNTAG[t](x) for t, x in zip(tags, vals.tolist())]
        return list(v)


def _small_int(n: int):
    """The smallest unsigned numpy integer type holding codes ``0 .. n - 1``."""
    import numpy as np
    return np.uint8 if n <= 0x100 else np.uint16 if n <= 0x10000 else np.uint32


def _piece(chunk, a: int, b: int):
    """Rows *a* to *b* (excluded) of an encoded chunk, as a chunk."""
    kind, data = chunk
    if kind != "cols":
        return (kind, data[a:b])
    cols: list = []
    for codec, v in data:
        if codec == "none":
            cols.append((codec, None))
        elif codec in _TAGGED:
            cols.append((codec, (v[0][a:b], v[1][a:b])))
        else:
            cols.append((codec, v[a:b]))
    return ("cols", cols)


def _chunk_bytes(chunk) -> int:
    """Approximate bytes held by an encoded chunk (the buffers; 8 bytes per object reference)."""
    kind, data = chunk
    if kind == "spill":
        return 0
    if kind != "cols":
        return 120 * len(data)   # a tuple and its values, roughly
    size = 0
    for codec, v in data:
        if codec == "none":
            continue
        if codec in _TAGGED:
            tags, vals = v
            size += len(tags) + vals.itemsize * len(vals)
        elif codec == "obj":
            size += 8 * len(v)
        elif isinstance(v, array):
            size += v.itemsize * len(v)
        else:
            size += len(v)
    return size

