"""Shared test helpers: the small simulation builders and trace filters that several
test files need.  Test files import them with ``from conftest import ...`` (this
directory is on ``sys.path`` under pytest's default import mode).

Times are in seconds, as in the public API.
"""

import os

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")      # before anything imports matplotlib

from netcosim import Simulation  # noqa: E402


def executes(C):
    """A task body whose every job executes for *C* seconds of CPU time."""
    def body(ctx):
        yield ctx.execute(C)
    return body


def periodic_task(body, *, period, name="t", priority=1, until=None, seed=0, **node_kw):
    """A simulation with one node ``"cpu"`` (``node_kw`` go to :meth:`Simulation.node`)
    running *body* every *period* seconds; run until *until* seconds if given."""
    sim = Simulation(seed=seed)
    sim.node("cpu", **node_kw).periodic(body, period=period, priority=priority, name=name)
    if until is not None:
        sim.run(until=until)
    return sim


def frame_rows(net, event, node=None, *, src=None):
    """The rows of network *net*'s frame table with this ``event`` (and, if given, this
    ``node`` and ``src``), renumbered from 0."""
    df = net.frames()
    df = df[df["event"] == event]
    if node is not None:
        df = df[df["node"] == node]
    if src is not None:
        df = df[df["src"] == src]
    return df.reset_index(drop=True)


class SteppingClock:
    """A fake wall clock for CPU-time models: each measured block (two reads, at its
    start and end) lasts the next of the given durations (s)."""

    def __init__(self, durations):
        self.t, self.durations, self.inside = 0.0, iter(durations), False

    def __call__(self):
        if self.inside:
            self.t += next(self.durations)
        self.inside = not self.inside
        return self.t


def wait_until(predicate, timeout=10.0, interval=0.01, *, what=None):
    """Poll ``predicate()`` every *interval* s until it returns a true value (returned);
    AssertionError naming *what* was awaited (default: the predicate's name or source
    text) after *timeout* s.  For waiting on a peer: a fixed sleep is slow when the peer
    is quick and flaky when the machine is loaded."""
    import time
    deadline = time.monotonic() + timeout
    while True:
        got = predicate()
        if got:
            return got
        if time.monotonic() >= deadline:
            if what is None:
                import inspect
                try:
                    what = inspect.getsource(predicate).strip()
                except (OSError, TypeError):
                    what = getattr(predicate, "__qualname__", repr(predicate))
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(interval)


def run_hil_cli(args, *, module, node, messages, timeout=120, expect=()):
    """Run ``netcosim hil ARGS --remote-cmd 'python -m MODULE'`` and the remote command it
    prints, as two real processes; check that the printed command starts *module* for
    *node* and that both sides counted *messages* messages each way (replies in flight
    at the end count as ``after the end``), and that every regular expression of *expect*
    matches the simulation side's output.  Returns the process's last stdout."""
    import ast
    import re
    import subprocess
    import sys
    import tempfile
    from pathlib import Path
    root = Path(__file__).resolve().parent.parent
    out_dir = tempfile.mkdtemp(prefix="netcosim-hil-")
    env = dict(os.environ, PYTHONPATH=str(root))
    sim_side = subprocess.Popen(
        [sys.executable, "-m", "netcosim.cli", "hil", *args, "--out", out_dir,
         "--remote-cmd", f"{sys.executable} -m {module}"],
        cwd=root, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    remote = None
    try:
        assert sim_side.stdout is not None
        assert sim_side.stdout.readline().strip() == "start the remote side with:"
        cmd = sim_side.stdout.readline().split()
        assert cmd[0] == sys.executable and cmd[1:3] == ["-m", module]
        assert cmd[cmd.index("--node") + 1] == node
        assert cmd[cmd.index("--connect") + 1].startswith("tcp/127.0.0.1:")
        assert re.fullmatch(r"[0-9a-f]{16}", cmd[cmd.index("--session") + 1])
        remote = subprocess.Popen(cmd, cwd=root, env=env, stdout=subprocess.PIPE, text=True)
        out, err = sim_side.communicate(timeout=timeout)
        assert sim_side.returncode == 0, err
        m = re.search(rf"requests to the remote: {messages} published \(0 overruns, 0 unserved\), replies applied: "
                      r"(\d+) \(\+(\d+) after the end\), expired: (\d+), dropped: (\{.*?\}), refused claimants: 0",
                      out)
        assert m, out
        late = ast.literal_eval(m[4]).get("late", 0)
        assert int(m[1]) + int(m[2]) + late == messages and set(ast.literal_eval(m[4])) <= {"late"}, out
        assert re.search(r"response time \(simulated\): median [0-9.]+ ms, p90 [0-9.]+ ms, p99", out), out
        assert "trace and counters written to" in out
        for pattern in expect:
            assert re.search(pattern, out), (pattern, out)
        r_out, _ = remote.communicate(timeout=30)
        assert f'"received": {messages}, "published": {messages}' in r_out
        return r_out
    finally:
        for p in (sim_side, remote):
            if p is not None and p.poll() is None:
                p.kill()
            if p is not None:
                p.wait(timeout=10)


def frame_from_tuples(rec):
    """Recorder *rec*'s table as ``pandas.DataFrame.from_records`` builds it from the stored
    tuples (the reference the column-wise read must equal)."""
    from netcosim.trace import Trace
    ref = Trace().table(rec.name, rec.columns, rec.categorical, rec.transform,
                        time=rec.columns[rec.time_index] if rec.time_index is not None else None)
    ref._buf = list(rec._buf)
    ref.providers = rec.providers
    return ref.frame()


def lossy_link():
    """A finished run: IdealLink a -> b at 1 Mbit/s losing half the frames (seed 3), a 300-bit
    frame every ms for 10 ms, run to 20 ms."""
    from netcosim import Simulation
    from netcosim.network import IdealLink
    sim = Simulation(seed=3)
    net = IdealLink(sim, "link", data_rate=1e6, loss=0.5)
    a = net.attach("a")
    net.attach("b")
    for k in range(10):
        sim.call_at(k * 1e-3, lambda: a.send("b", None, 300))
    sim.run(0.02)
    return sim


def assert_every_request_accounted(c: dict, samples: int, *, extra_drops=(), process=None) -> None:
    """The counters *c* of a HIL remote (``RemoteNode.counters()``) account for every one of
    *samples* requests whatever the machine's load: each is published, or is an overrun
    (its predecessor still unanswered: counted, not published); each published one is
    answered in time (``received``), too late (dropped ``late``, counted) or after the end;
    nothing unserved, no drop but ``late`` and *extra_drops*.  *process*: the remote
    process's own counters (``HilRun.process``), which must match."""
    assert c["published"] + c["overruns"] == samples and c["published"] > 0, c
    assert c["unserved"] == 0, c
    assert set(c["dropped"]) <= {"late", *extra_drops}, c
    assert c["received"] + c["after_end"] + c["dropped"].get("late", 0) == c["published"], c
    if process is not None:
        assert process["received"] == process["published"] == c["published"], process


@pytest.fixture(scope="session")
def fmu_builder(tmp_path_factory):
    """``get(model, fmi, **options)``: the path of a test FMU compiled from ``netcosim/fmi/csrc/``
    (see ``tests/fmu_build.py``), built once per session and option set.  Skips when FMPy
    (the ``fmi`` extra) or gcc is missing."""
    import shutil
    pytest.importorskip("fmpy", reason="FMPy (pip install 'netcosim[fmi]') is not installed")
    if shutil.which("gcc") is None:
        pytest.skip("gcc is needed to build the test FMUs")
    from fmu_build import build_fmu
    root = tmp_path_factory.mktemp("fmus")
    cache: dict = {}

    def get(model, fmi, **options):
        key = (model, fmi, tuple(sorted(options.items())))
        if key not in cache:
            cache[key] = build_fmu(model, fmi, root / f"build{len(cache)}", **options)
        return cache[key]
    return get
