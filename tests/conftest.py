"""Shared test helpers: the small simulation builders and trace filters that several
test files need.  Test files import them with ``from conftest import ...`` (this
directory is on ``sys.path`` under pytest's default import mode).

Times are in seconds, as in the public API.
"""

import os

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
