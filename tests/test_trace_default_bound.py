"""The default trace is bounded (issue 23, "long runs"): a ``keep``-mode table holds at
most its memory budget of encoded rows; older chunks move to a temporary file and are
read back, bit for bit, when the table is read.  A small budget stands in for the
default 4 MiB so that a short run spills."""

import os

import pandas as pd
import pytest

import netcosim.recorder as trace_mod
from benchmarks.memory import build
from netcosim.columns import ColumnStore, _chunk_bytes
from netcosim.errors import ConfigurationError

BUDGET = 8 * 1024   # bytes of encoded rows per table
UNTIL = 3.0         # simulated s: ~18 000 rows over five tables


def _run(memory_default, until=UNTIL, configure=None):
    old = trace_mod.DEFAULT_MEMORY
    trace_mod.DEFAULT_MEMORY = memory_default
    try:
        sim = build("default")          # the soak scenario: servo over 802.11b, 70 % loss
        if configure is not None:
            configure(sim)
        sim.run(until)
    finally:
        trace_mod.DEFAULT_MEMORY = old
    return sim


@pytest.fixture(scope="module")
def runs():
    return _run(BUDGET), _run(None)


def _held(store: ColumnStore) -> int:
    return sum(_chunk_bytes(ch) for _, ch in store._chunks)


def test_default_budget_is_4_mib_and_keep_mode():
    sim = build("default")
    for name in sim.trace.tables:
        rec = sim.trace._tables[name]
        assert rec.mode == "keep" and rec.memory == trace_mod.DEFAULT_MEMORY == 4 * 2 ** 20
        assert rec._buf.memory == 4 * 2 ** 20 and rec.options == {}


def test_every_table_stays_within_its_budget_and_spills_the_rest(runs):
    bounded, _ = runs
    for name in ("signals", "schedule", "jobs", "frames", "network_schedule"):
        store = bounded.trace._tables[name]._buf
        assert type(store) is ColumnStore
        biggest = max(_chunk_bytes(ch) for _, ch in bounded.trace._tables[name]._buf._chunks
                      if ch[0] != "spill")
        assert _held(store) <= BUDGET + biggest, name
        # the rest is in the file
        assert 0 < store.spilled_rows and store._n - store.spilled_rows == sum(
            n for n, ch in store._chunks if ch[0] != "spill"), name
        assert store.spills >= 1 and store._file is not None


def test_unbounded_keep_never_spills(runs):
    _, unbounded = runs
    for name in unbounded.trace.tables:
        store = unbounded.trace._tables[name]._buf
        assert store.memory is None and store.spilled_rows == 0 and store._file is None


@pytest.mark.parametrize("name", ["signals", "schedule", "jobs", "frames", "network_schedule"])
def test_spilled_table_reads_back_bit_for_bit(runs, name):
    bounded, unbounded = runs
    a, b = bounded.trace.frame(name), unbounded.trace.frame(name)
    assert len(a) > 500 and len(bounded.trace._tables[name]) > 500
    pd.testing.assert_frame_equal(a, b, check_exact=True)
    # the stored rows, by iteration and by index (both read the file too); the two runs'
    # rows hold different task objects, so they are compared within the bounded run
    rows = bounded.trace._tables[name].rows
    stored = list(rows)
    assert len(stored) == len(bounded.trace._tables[name])
    for i in (0, 1, 257, len(stored) // 2, len(stored) - 1):
        assert rows[i] is stored[i] or repr(rows[i]) == repr(stored[i])


def test_signals_and_parquet_read_back_equal(runs, tmp_path):
    bounded, unbounded = runs
    pd.testing.assert_frame_equal(bounded.trace.signals(wide=True), unbounded.trace.signals(wide=True),
                                  check_exact=True)
    pd.testing.assert_series_equal(bounded.trace.signal("servo", "y.y"), unbounded.trace.signal("servo", "y.y"),
                                   check_exact=True)
    fa = bounded.trace.to_parquet(tmp_path / "a")
    fb = unbounded.trace.to_parquet(tmp_path / "b")
    assert [f.name for f in fa] == [f.name for f in fb]
    for x, y in zip(fa, fb):
        pd.testing.assert_frame_equal(pd.read_parquet(x), pd.read_parquet(y), check_exact=True)


def test_one_temporary_file_per_table_created_once_and_deleted_by_clear():
    sim = _run(BUDGET, until=1.0)
    store = sim.trace._tables["frames"]._buf
    f, spills = store._file, store.spills
    assert f is not None and spills >= 1
    sim.run(2.0)                       # more spills, into the same file
    assert store.spills > spills and store._file is f
    assert os.fstat(f.fileno()).st_size > 0
    sim.trace.clear("frames")
    assert store._file is None and f.closed and store.spilled_rows == 0 and len(store) == 0
    sim.run(2.5)      # recording goes on after the clear, within the budget again
    # (a stored row may stand for a frame's created and queued rows: tracing.NetworkNames.two)
    assert 0 < len(store) <= len(sim.trace.frame("frames")) < 2 * len(store)


def test_memory_option_validation_and_options():
    sim = build("default")
    with pytest.raises(ConfigurationError, match="memory"):
        sim.trace.configure("signals", "keep", memory=0)
    with pytest.raises(ConfigurationError, match="memory"):
        sim.trace.configure_all("keep", memory=-5)
    sim.trace.configure("signals", "keep", memory=None)
    assert sim.trace._tables["signals"].options == {"memory": None}
    assert sim.trace._tables["signals"]._buf.memory is None
    sim.trace.configure_all("keep", memory=1 << 20)
    assert all(sim.trace._tables[n]._buf.memory == 1 << 20 for n in sim.trace.tables)
    sim.trace.configure("jobs", "ring", rows=10)     # ignored by the other modes
    assert sim.trace._tables["jobs"].options == {"rows": 10}


def test_reconfiguring_a_spilled_table_keeps_its_rows():
    sim = _run(BUDGET, until=2.0)
    before = sim.trace.frame("frames")
    assert sim.trace._tables["frames"]._buf.spilled_rows > 0
    sim.trace.configure("frames", "keep", memory=None)
    assert sim.trace._tables["frames"]._buf.spilled_rows == 0
    pd.testing.assert_frame_equal(sim.trace.frame("frames"), before, check_exact=True)


@pytest.mark.parametrize("name", ["frames", "network_schedule"])
def test_network_transforms_give_the_same_frame_from_categoricals(runs, name):
    # the network tables store codes (netcosim.network.tracing): read back from the file,
    # their transforms build the name categoricals from the codes, turn integer time into s
    # and drop the schedule's same-instant and repeated states
    from netcosim.network.tracing import FRAME_RAW, SCHEDULE_RAW
    bounded, unbounded = runs
    assert bounded.trace._tables[name].columns == (FRAME_RAW if name == "frames" else SCHEDULE_RAW)
    assert bounded.trace._tables[name]._buf.spilled_rows > 0
    got = bounded.trace.frame(name)
    assert isinstance(got["node"].dtype, pd.CategoricalDtype) and set(got["network"]) == {"wlan"}
    pd.testing.assert_frame_equal(got, unbounded.trace.frame(name), check_exact=True)


def test_keeps_categories_with_a_transform_that_drops_rows():
    from netcosim.trace import Trace

    def drop_b(df):
        return df[df["name"] != "b"].reset_index(drop=True)
    frames = []
    for memory in (64, None):
        tr = Trace()
        rec = tr.table("x", ("time", "name", "v"), categorical=("name",), transform=drop_b, keeps_categories=True)
        tr.configure("x", "keep", memory=memory)
        for i in range(3000):
            rec.rows.append((i, "b" if i % 3 == 0 else ("z" if i % 2 else "a"), i * 0.5))
        tr.maintain()
        assert (rec._buf.spilled_rows > 0) == (memory is not None)
        frames.append(tr.frame("x"))
    pd.testing.assert_frame_equal(frames[0], frames[1], check_exact=True)
    assert list(frames[0]["name"].cat.categories) == ["a", "z"]


@pytest.mark.parametrize("name", ["signals", "schedule", "jobs", "frames", "network_schedule"])
def test_column_wise_read_equals_the_frame_built_from_tuples(runs, name):
    # the column-wise read (categoricals from codes, ticks to seconds in place, repeated
    # network states dropped from the codes) against from_records on the stored tuples
    from conftest import frame_from_tuples
    bounded, _ = runs
    rec = bounded.trace.recorder(name)
    got = rec.frame()
    assert len(got) > 500
    pd.testing.assert_frame_equal(got, frame_from_tuples(rec), check_exact=True)


def test_repeated_network_states_are_dropped_alike_from_codes_and_from_names():
    # the stored schedule rows (a row per change: several per node and instant in keep mode)
    # read back as one row per node and instant with the instant's last state, a row that
    # repeats its node's previous state dropped: the vectorised reading against a row-by-row
    # reference on random rows (two networks, three nodes, ~a third repeating)
    import numpy as np

    from netcosim.network.tracing import NetworkNames
    rng = np.random.default_rng(5)
    n = 200_000
    names = NetworkNames()
    codes = [[names.state_codes(net, node) for node in ("a", "b", "c")] for net in ("can", "wlan")]
    states = ("idle", "sending", "waiting")
    nets, nodes, st = rng.integers(0, 2, n), rng.integers(0, 3, n), rng.integers(0, 3, n)
    ticks = np.cumsum(rng.integers(0, 3, n) * (rng.random(n) < 0.5)).astype(np.int64)
    code = np.array([codes[a][b][states[c]] for a, b, c in zip(nets, nodes, st)], dtype=np.int64)
    got = names.schedule_frame(pd.DataFrame({"time": ticks, "code": code}))
    # reference: one row per (node, instant) at its first change, with the instant's last state
    rows, last_t, at = [], {}, {}
    for t, a, b, c in zip(ticks.tolist(), nets.tolist(), nodes.tolist(), st.tolist()):
        if last_t.get((a, b)) == t:
            rows[at[(a, b)]][3] = states[c]
        else:
            last_t[(a, b)], at[(a, b)] = t, len(rows)
            rows.append([t, ("can", "wlan")[a], "abc"[b], states[c]])
    prev, keep = {}, []
    for r in rows:
        if prev.get((r[1], r[2])) != r[3]:
            keep.append(r)
        prev[(r[1], r[2])] = r[3]
    want = pd.DataFrame(keep, columns=["time", "network", "node", "state"])
    want["time"] = want["time"] * 1e-12
    for c in ("network", "node", "state"):
        want[c] = want[c].astype("category")
    assert 0.4 * n < len(got) < 0.7 * n
    pd.testing.assert_frame_equal(got, want, check_exact=True)
