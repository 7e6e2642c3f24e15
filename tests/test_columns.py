"""Columnar trace storage: rows come back as the very values appended (types and bits),
whatever mix of types a column holds, and the DataFrames built from them are identical
to those built from tuples."""

import math
import sys

import numpy as np
import pandas as pd
import pytest
from conftest import frame_from_tuples

from netcosim import Simulation
from netcosim.columns import ColumnStore
from netcosim.trace import Trace


def same(a, b) -> bool:
    """Same type and same value (NaN equal to NaN, -0.0 distinct from 0.0)."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float):
        return (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1, a) == math.copysign(1, b))
    return a == b


def assert_same_rows(got, want):
    assert len(got) == len(want)
    for r, w in zip(got, want):
        assert len(r) == len(w) and all(same(x, y) for x, y in zip(r, w)), (r, w)


ROWS = [
    # int, float, mixed numbers/None, bool, str, big int, signed zero, NaN/int/bool, object
    (1, 2.5, None, True, "a", 2**60, -0.0, math.nan, ("payload",)),
    (3, 7.0, 1.5, False, "b", 2**70, 1.0, 2, None),
    (-4, math.inf, 7, False, "a", 5, 0.0, True, 3),
] * 7


def test_every_codec_round_trips_exactly():
    store = ColumnStore(len(ROWS[0]), chunk_rows=4)
    for r in ROWS:
        store.append(r)
    assert store._n == 0 and len(store) == 21      # appending only appends
    store.maintain()
    # 21 rows: four chunks of 4 encoded, fewer than 2 * 4 tuples after them
    assert len(store) == 21 and store._n == 16 and len(store._tail) == 5
    codecs = [codec for codec, _ in store._chunks[0][1][1]]
    assert codecs == ["q", "d", "fnone", "bool", "str", "obj", "d", "mixed", "obj"]
    assert_same_rows(list(store), ROWS)
    assert_same_rows([store[i] for i in range(21)], ROWS)
    assert same(store[-1][1], math.inf)
    assert_same_rows([store[-21]], [ROWS[0]])
    with pytest.raises(IndexError, match="row 21 out of range"):
        store[21]


def test_strings_are_stored_once_as_one_byte_codes():
    store = ColumnStore(2, chunk_rows=1000)
    # a fresh string object per row (as ctx.log builds "node.task"), 3 distinct values
    for i in range(2000):
        store.append((float(i), "".join(["node", ".", "task", str(i % 3)])))
    store.maintain()
    codec, codes = store._chunks[0][1][1][1]
    assert codec == "str" and isinstance(codes, bytes) and len(codes) == 1000
    assert store._names[1] == ["node.task0", "node.task1", "node.task2"]
    assert [r[1] for r in store] == [f"node.task{i % 3}" for i in range(2000)]


def test_more_than_256_strings_use_two_byte_codes():
    store = ColumnStore(1, chunk_rows=300)
    for i in range(600):
        store.append((f"s{i}",))
    store.maintain()
    codec, codes = store._chunks[-1][1][1][0]
    assert codec == "str" and codes.itemsize == 2
    assert [r[0] for r in store] == [f"s{i}" for i in range(600)]


def test_integers_beyond_two_to_the_53_among_floats_stay_exact():
    store = ColumnStore(1, chunk_rows=2)
    rows = [(2**53 + 1,), (0.5,), (1,), (0.25,)]
    for r in rows:
        store.append(r)
    store.maintain()
    kinds = [chunk[1][1][0][0] for chunk in store._chunks]
    assert kinds == ["obj"]          # the first chunk could not be doubles
    assert_same_rows(list(store), rows)


def test_rows_of_the_wrong_length_are_kept_as_rows():
    store = ColumnStore(2, chunk_rows=2)
    rows = [(1, 2), (3,), (4, 5), (6, 7), (8, 9)]
    for r in rows:
        store.append(r)
    store.maintain()
    assert store._chunks[0][1][0] == "rows"
    assert list(store) == rows


def test_replace_finds_a_row_by_identity_then_by_value_in_the_newest_chunk():
    store = ColumnStore(2, chunk_rows=2)
    first = (0, "idle")
    store.append(first)
    for i in range(1, 4):
        store.append((i, "x"))
    store.maintain()
    assert store._n == 2                   # `first` was encoded: matched by value now
    assert store.replace(first, (0, "sending")) and store[0] == (0, "sending")
    last = (9, "waiting")
    store.append(last)
    assert store.replace(last, (9, "idle")) and store[-1] == (9, "idle")
    assert not store.replace((42, "never"), (0, "x"))


def test_clear_keeps_the_codes_valid():
    store = ColumnStore(1, chunk_rows=2)
    for s in "abcde":
        store.append((s,))
    store.clear()
    assert len(store) == 0 and list(store) == []
    for s in "edcba":
        store.append((s,))
    assert [r[0] for r in store] == list("edcba")


def test_columnar_storage_is_much_smaller_than_tuples():
    store = ColumnStore(4, chunk_rows=1024)
    rows = [(i * 1e-3, "servo", "y.y", i * 0.5) for i in range(1024 * 8)]
    for r in rows:
        store.append(r)
    store.maintain()
    encoded = sum(c[1][1][0][1].itemsize * 1024 * 2 + 2 * 1024 for c in store._chunks)
    per_row_encoded = encoded / store._n
    per_row_tuple = sys.getsizeof(rows[0]) + 2 * sys.getsizeof(1.5) + 8  # tuple, two floats, list slot
    assert per_row_encoded == 18.0 and per_row_tuple >= 3 * per_row_encoded


def logging_sim(n_jobs: int) -> Simulation:
    sim = Simulation()
    cpu = sim.node("cpu")

    @cpu.periodic(period=1e-3, priority=1)
    def t(ctx):
        ctx.log("k", ctx.job.index)
        ctx.log("half", ctx.job.index / 2)
        yield ctx.execute(1e-4)
    sim.run(n_jobs * 1e-3)
    return sim


def test_frames_equal_those_built_from_tuples():
    sim = logging_sim(3000)           # thousands of rows per table: several encoded chunks
    trace = sim.trace
    for name in ("signals", "schedule", "jobs"):
        rec = trace._tables[name]
        assert rec._buf._n > 0
        pd.testing.assert_frame_equal(rec.frame(), frame_from_tuples(rec), check_exact=True)
    assert list(trace.jobs()["job"]) == list(range(3000))


def test_a_run_encodes_as_it_goes_and_at_its_end():
    sim = logging_sim(100)
    store = sim.trace._tables["schedule"]._buf
    # 300 rows: fewer than two chunks stay tuples after the run's final maintain()
    assert len(store) == 300 and store._n == 0
    sim = Simulation()
    cpu = sim.node("cpu")
    cpu.periodic(lambda ctx: None, period=1e-3, priority=1, name="t")
    store = sim.trace._tables["schedule"]._buf
    seen = []
    cpu.periodic(lambda ctx: seen.append(len(store._tail)), period=1e-3, offset=5e-4, priority=2, name="probe")
    sim.run(1.0)
    # every 256 events at most: the tuple tail never holds much more than two chunks
    assert store._n > 0 and max(seen) < 2 * store.chunk_rows + 256 * 3
    assert len(store) == 6 * 1000


def plant_logging_sim(**configure):
    """The README servo with ExactZOH for 0.3 s; the plant logs 4 signals per read and write."""
    from netcosim import ExactZOH
    from netcosim.controllers.pid import PID
    from netcosim.plants.dc_servo import DCServo
    sim = Simulation(seed=1)
    if configure:
        sim.trace.configure("signals", **configure)
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], integrator=ExactZOH())
    cpu = sim.node("controller", context_switch=20e-6)
    pid = PID(h=0.006)

    @cpu.periodic(period=0.006, priority=1)
    def control(ctx):
        u = pid.compute(1.0, ctx.read(servo.output("y")))
        yield ctx.execute(0.002)
        ctx.write(servo.input("u"), u)
    sim.run(0.3)
    return sim.trace.signals()


@pytest.mark.parametrize("configure, pick", [
    (dict(mode="ring", rows=10), lambda df: df.iloc[-10:]),
    (dict(mode="window", seconds=0.05), lambda df: df[df["time"] >= 0.3 - 0.05]),
    (dict(mode="off"), "empty"),
    (dict(mode="keep", every=3), None),
])
def test_plant_logs_written_several_rows_at_once_obey_every_mode(configure, pick):
    keep = plant_logging_sim()
    # 50 jobs: a read (one log) and a write (two logs), 4 signals each, and the state at
    # t = 0 (the first read comes after the 20 us context switch: default grid until then)
    assert len(keep) == 50 * 3 * 4 + 4
    got = plant_logging_sim(**configure)
    if pick == "empty":
        assert len(got) == 0 and list(got.columns) == list(keep.columns)
        return
    if pick is None:  # every 3rd sample of each (source, signal)
        want = keep[keep.groupby(["source", "signal"], observed=True).cumcount() % 3 == 0]
    else:
        want = pick(keep)
    pd.testing.assert_frame_equal(got.reset_index(drop=True), want.reset_index(drop=True), check_categorical=False)


def test_maintain_with_a_budget_encodes_chunk_by_chunk_and_resumes():
    store = ColumnStore(2, chunk_rows=4)
    rows = [(float(i), i) for i in range(20)]
    store.extend(rows)
    asked = []

    def once():                     # the budget runs out after the first chunk
        asked.append(1)
        return False
    assert store.maintain(once) is False
    assert store._n == 4 and len(asked) == 1      # one chunk, then asked before the second
    assert store.maintain(lambda: True) is True
    assert store._n == 16 and len(store._tail) == 4    # fewer than 2 * chunk_rows stay tuples
    assert list(store) == rows


def test_trace_maintain_stops_when_the_budget_is_spent():
    trace = Trace(clock=lambda: 0)
    a = trace.table("a", ("x",))
    b = trace.table("b", ("y",))
    for i in range(3 * 256):
        a.append((i,))
        b.append((float(i),))
    assert trace.maintain(lambda: False) is False        # one chunk of table a only
    assert (a._buf._n, b._buf._n) == (256, 0)
    assert trace.maintain() is True
    assert (a._buf._n, b._buf._n) == (512, 512)
    assert list(trace.frame("a")["x"]) == list(range(768))


def test_uint8_columns_store_one_byte_a_row_and_read_back_as_ints():
    store = ColumnStore(2, chunk_rows=4, dtypes=("int", "uint8"))
    rows = [(10 * i, i % 4) for i in range(12)]
    store.extend(rows)
    store.maintain()
    assert store._chunks[0][1][1][1] == ("u8", bytes([0, 1, 2, 3]))
    assert_same_rows(list(store), rows)
    bad = ColumnStore(1, chunk_rows=1, dtypes=("uint8",))   # 300 does not fit: checked by type
    bad.extend([(300,), (1,), (2,)])
    bad.maintain()
    assert_same_rows(list(bad), [(300,), (1,), (2,)])


def test_schedule_rows_hold_the_task_and_a_state_code_and_read_as_names():
    from netcosim.kernel.tables import SCHEDULE_RAW, STATE_CODES
    sim = Simulation()
    cpu = sim.node("cpu")
    task = cpu.periodic(lambda ctx: None, period=0.01, priority=1, name="a")
    sim.run(until=0.015)
    assert sim.trace.recorder("schedule").columns == SCHEDULE_RAW
    assert list(sim.trace.recorder("schedule")._buf)[:2] == [(0, task, STATE_CODES["ready"]),
                                                     (0, task, STATE_CODES["running"])]
    df = sim.trace.frame("schedule")
    assert list(df.columns) == ["time", "node", "task", "state"]
    assert list(df["state"]) == ["ready", "running", "idle"] * 2
    assert list(df["node"].cat.categories) == ["cpu"] and all(df["task"] == "a")


def test_floats_with_none_read_back_as_one_float_column():
    # a frame's backoff or bits: floats, with None where the event has none (codec "fnone");
    # read column-wise as from_records reads the tuples: float64, None as NaN, bits kept
    rows = [(i, None if i % 3 == 0 else (-0.0 if i % 5 == 0 else i * 0.25)) for i in range(2000)]
    rows += [(i, None) for i in range(2000, 2600)]      # chunks of None only in between
    rows += [(i, float(i)) for i in range(2600, 3600)]  # and of floats only
    store = ColumnStore(2, chunk_rows=256, memory=1024)
    for r in rows:
        store.append(r)
    store.maintain()
    assert store.spilled_rows > 0
    codecs = [ch[1][1][0] for _, ch in store._chunks_in_order()]
    assert {"fnone", "none", "d"} <= set(codecs)
    got = store.frame(("i", "x"))
    ref = pd.DataFrame.from_records(rows, columns=["i", "x"])
    assert got["x"].dtype == np.float64
    pd.testing.assert_frame_equal(got, ref, check_exact=True)
    assert np.signbit(got["x"].to_numpy()[5]) and np.isnan(got["x"].to_numpy()[0])
    assert_same_rows(list(store), rows)


@pytest.mark.parametrize("chunks", [
    [("inone", lambda i: None if i % 4 == 0 else i * 3)],             # a frame's bits
    [("q", lambda i: i), ("d", lambda i: i * 0.5)],                     # ints, then floats
    [("q", lambda i: 2**53 + i), ("none", lambda i: None)],             # large ints, then None
    [("fnone", lambda i: None if i % 3 else -0.0), ("inone", lambda i: None if i % 2 else i)],
])
def test_numeric_columns_of_several_codecs_read_back_as_from_records_makes_them(chunks):
    rows = []
    for _, value in chunks:
        rows += [(len(rows) + i, value(i)) for i in range(1024)]
    store = ColumnStore(2, chunk_rows=256, memory=2048)
    for r in rows:
        store.append(r)
    store.maintain()
    codecs = {ch[1][1][0] for _, ch in store._chunks_in_order()}
    assert {c for c, _ in chunks} <= codecs
    got = store.frame(("i", "x"))
    ref = pd.DataFrame.from_records(rows, columns=["i", "x"])
    assert got["x"].dtype == ref["x"].dtype == np.float64
    pd.testing.assert_frame_equal(got, ref, check_exact=True)
