"""Spilled column chunks: runs of chunks written to the table's file read back as the very
rows appended (types, NaN bits, -0.0), whatever codecs the chunks mix and however often
the store spills."""

import math
import struct

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from netcosim.columns import ColumnStore


def same(a, b) -> bool:
    """Same type and same value; floats bit for bit (NaN payloads, -0.0)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float):
        return struct.pack("<d", a) == struct.pack("<d", b)
    return a == b


def assert_same_rows(got, want):
    assert len(got) == len(want)
    for i, (r, w) in enumerate(zip(got, want)):
        assert len(r) == len(w) and all(same(x, y) for x, y in zip(r, w)), (i, r, w)


NAN2 = struct.unpack("<d", struct.pack("<Q", 0x7FF8_0000_0000_BEEF))[0]   # a NaN with a payload


def block(kind: str, start: int, n: int) -> list[tuple]:
    """*n* rows of 7 columns; column 3's codec chosen by *kind*, the others steady or varied."""
    rows = []
    for j in range(start, start + n):
        if kind == "fnone":
            x = None if j % 3 == 0 else (-0.0 if j % 5 == 0 else (NAN2 if j % 7 == 0 else j * 0.25))
        elif kind == "inone":
            x = None if j % 4 == 0 else j * 3 - 10**12
        elif kind == "mixed":
            x = (True, None, 1.5, -0.0)[j % 4]
        elif kind == "mixedq":
            x = (False, 7, None, -2**40)[j % 4]   # within 2**53: next to floats, mixed as doubles
        elif kind == "bool":
            x = j % 3 == 0
        elif kind == "none":
            x = None
        elif kind == "obj":
            x = ("payload", j)
        elif kind == "q":
            x = j - 2**40
        else:
            x = float(j) if j % 11 else math.inf
        rows.append((
            j * 1e-3,                       # d
            f"name{j % (start // 16 + 2)}",  # str: more names over time (bytes, then 'H' codes)
            j % 256,                        # uint8 (declared)
            x,
            j % 2 == 1,                     # bool
            None,                           # none
            j,                              # q
        ))
    return rows


KINDS = ["d", "fnone", "inone", "mixed", "mixedq", "bool", "none", "obj", "q"]


def store_of(rows, memory, chunk_rows=64):
    store = ColumnStore(7, chunk_rows=chunk_rows, memory=memory,
                        dtypes=(None, None, "uint8", None, None, None, None))
    for i, r in enumerate(rows):
        store.append(r)
        if i % 500 == 0:
            store.maintain()
    store.maintain()
    return store


def mixed_rows(pattern, size):
    rows: list[tuple] = []
    for kind in pattern:
        rows += block(kind, len(rows), size)
    return rows


@pytest.mark.parametrize("memory", [1, 600, 5000, 40_000])
def test_spilled_runs_of_every_codec_read_back_exactly(memory):
    # mixed values as doubles next to mixed values as integers: same codecs, other typecode
    pattern = ["d", "d", "fnone", "fnone", "inone", "mixed", "mixedq", "obj", "mixedq", "bool", "none",
               "none", "q", "fnone", "obj", "obj", "d"] * 4
    rows = mixed_rows(pattern, 150)
    store = store_of(rows, memory)
    assert store.spills >= 3 and store.spilled_rows > 0
    spilled = [(n, ch) for n, ch in store._chunks_in_order()]
    codecs = {ch[1][3][0] for _, ch in spilled if ch[0] == "cols"}
    assert {"d", "fnone", "inone", "mixed", "bool", "none", "obj", "q"} <= codecs
    kinds = {type(ch[1][1][1]).__name__ for _, ch in spilled if ch[0] == "cols"}
    assert kinds == {"bytes", "array"}     # codes of one byte, then of two
    if memory > 1000:   # several chunks a spill: runs of them merged
        assert max(n for n, _ in spilled) > store.chunk_rows
    assert sum(n for n, _ in spilled) == store._n
    assert_same_rows(list(store), rows)
    for i in (0, 1, 63, 64, 65, len(rows) // 3, len(rows) // 2 + 7, len(store) - 1, -1):
        assert all(same(a, b) for a, b in zip(store[i], rows[i])), i
    ref = pd.DataFrame.from_records(rows, columns=list("abcdefg"))
    got = store.frame(list("abcdefg"))
    pd.testing.assert_frame_equal(got, ref, check_exact=True)
    # spilling again after reading: the file keeps growing, every row still exact
    more = mixed_rows(["fnone", "obj", "d"], 300)
    more = [(r[0], r[1], r[2], r[3], r[4], r[5], r[6] + len(rows)) for r in more]
    for r in more:
        store.append(r)
    store.maintain()
    assert_same_rows(list(store), rows + more)


def test_spilling_changes_neither_rows_nor_memory_accounting():
    rows = mixed_rows(["d", "fnone", "none", "obj", "q"] * 6, 200)
    bounded, unbounded = store_of(rows, 2000), store_of(rows, None)
    assert bounded.spills > 1 and unbounded.spills == 0
    assert_same_rows(list(bounded), list(unbounded))
    # only obj chunks and the newest chunk stay in memory
    for n, ch in bounded._chunks[:-1]:
        assert ch[0] == "spill" or any(codec == "obj" for codec, _ in ch[1])


@settings(max_examples=40, deadline=None)
@given(pattern=st.lists(st.sampled_from(KINDS), min_size=1, max_size=12),
       size=st.integers(1, 200), memory=st.sampled_from([1, 300, 3000, None]),
       chunk_rows=st.sampled_from([1, 7, 64]))
def test_any_mix_of_chunks_reads_back_as_appended(pattern, size, memory, chunk_rows):
    rows = mixed_rows(pattern, size)
    store = store_of(rows, memory, chunk_rows)
    assert_same_rows(list(store), rows)
    if rows:
        assert all(same(a, b) for a, b in zip(store[len(rows) // 2], rows[len(rows) // 2]))
    got = store.frame(list("abcdefg"))
    pd.testing.assert_frame_equal(got, pd.DataFrame.from_records(rows, columns=list("abcdefg")),
                                  check_exact=True)
    assert np.array_equal(got["a"].to_numpy(), np.array([r[0] for r in rows], dtype=float))
