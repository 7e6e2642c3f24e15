"""A real-time clock for a :class:`~netcosim.Simulation` that other threads can wake.

:class:`RealtimeClock` paces the simulation to a wall clock (one simulated second takes
``factor`` wall-clock seconds) and owns a thread-safe inbox (:class:`queue.SimpleQueue`).
Any thread (a Zenoh callback, a test) calls :meth:`RealtimeClock.post`, which only
stamps the wall-clock time and puts ``(wall time, fn, arg)`` in the inbox; the
simulation thread, while it waits for the wall-clock time of the next event, wakes on
the inbox and schedules ``fn(arg)`` at the simulated time matching the stamp.  The
SimPy environment is touched only by the thread that calls ``sim.run``.

Why not ``Simulation(realtime=True)`` (SimPy's ``RealtimeEnvironment``): it sleeps
without a way to be woken by a message, and its strict mode is tied to SimPy's time
unit (1 ps here).  This clock records the lateness of every event (a bounded
histogram, :class:`Lateness`) and counts overruns beyond ``max_lag``.

The clock plugs into an existing simulation: it replaces the environment's ``step``
with its own paced step and marks the simulation real-time, so ``sim.run(until)``
keeps its meaning (finalizers, failure handling) unchanged.
"""

from __future__ import annotations

import gc
import math
import queue
import time
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
import pandas as pd
import simpy

from .. import validate
from ..clock import Engine
from ..errors import ConfigurationError
from ..timebase import RESOLUTION

__all__ = ["RealtimeClock", "Lateness", "LATENESS_EDGES", "DEFAULT_SPIN", "DEFAULT_REPLY_WINDOW"]

#: bin edges (s) of the lateness histogram: 0, then 1 us to 10 s, 10 bins per decade;
#: the last bin also holds everything later than 10 s
LATENESS_EDGES = np.concatenate(([0.0], np.logspace(-6, 1, 71)))

#: default busy-wait (s) before an event's due time (see :class:`RealtimeClock`)
DEFAULT_SPIN = 100e-6

#: housekeeping -- encoding the trace's rows (``sim.trace.maintain``) once at least
#: MAINTAIN_EVERY events have passed, and the garbage collector -- runs while the next
#: event is due more than MAINTAIN_SLACK s (wall clock) away, and stops HOUSEKEEPING_MARGIN
#: s (plus the busy-wait) before it is due; after MAINTAIN_FORCE events without such
#: slack it runs in full right after an event (memory first)
MAINTAIN_EVERY, MAINTAIN_SLACK, MAINTAIN_FORCE = 256, 1e-3, 8192
HOUSEKEEPING_MARGIN = 200e-6

#: default wait (s, wall clock) for the answer to a published message before housekeeping
#: may run anyway (see :meth:`RealtimeClock.expect_reply`)
DEFAULT_REPLY_WINDOW = 5e-3

_Inbox = "queue.SimpleQueue[tuple[float, Callable[..., Any], Any]]"


def _wait(inbox: queue.SimpleQueue, timeout: float):
    try:
        return inbox.get(timeout=timeout)
    except queue.Empty:
        return None


@dataclass
class Lateness:
    """How late (s, wall clock) the simulation thread processed its events.

    ``counts[i]`` events were processed between ``edges[i]`` and ``edges[i+1]`` s late
    (an event processed early, which only happens when it is already due, counts as 0
    s late); ``events`` is their total, ``overruns`` how many were more than
    ``max_lag`` s late, ``max`` the largest lateness (s).  ``injections`` messages were
    injected from the inbox, ``late_injections`` of them after the simulated instant
    matching their arrival had passed (they were injected at the current instant).
    """

    edges: np.ndarray
    counts: np.ndarray
    events: int
    overruns: int
    max: float
    max_lag: float
    injections: int
    late_injections: int

    def quantile(self, q: float) -> float:
        """Upper bin edge (s) below which at least a share *q* (0..1) of the events lie."""
        if self.events == 0:
            return math.nan
        cum = np.cumsum(self.counts)
        i = int(np.searchsorted(cum, q * self.events, side="left"))
        return float(self.edges[min(i + 1, len(self.edges) - 1)])

    def to_pandas(self) -> pd.DataFrame:
        """One row per histogram bin: ``low`` and ``high`` (s), ``events``."""
        return pd.DataFrame({"low": self.edges[:-1], "high": self.edges[1:], "events": self.counts})

    def plot(self, ax=None):
        """Bar plot of the histogram on a logarithmic lateness axis (s), on the matplotlib axes
        *ax* (None: a new figure); returns the axes."""
        import matplotlib.pyplot as plt
        if ax is None:
            _, ax = plt.subplots(figsize=(6, 3.5))
        lo = np.maximum(self.edges[:-1], 1e-7)
        ax.bar(lo, self.counts, width=self.edges[1:] - lo, align="edge")
        ax.set_xscale("log")
        ax.set_xlabel("lateness [s]")
        ax.set_ylabel("events")
        return ax


class RealtimeClock:
    """Pace *sim* to a wall clock and inject messages posted from other threads.

    Parameters
    ----------
    sim:
        The :class:`~netcosim.Simulation` to pace (its components may already exist).
    factor:
        Wall-clock seconds per simulated second (1.0: real time; 2.0: half speed).
    max_lag:
        An event processed more than ``max_lag`` seconds (wall clock) after its due
        time counts as an overrun (recorded, the run goes on).
    clock:
        The wall clock, seconds as a float (default :func:`time.monotonic`); tests pass a
        fake one.
    wait:
        ``wait(inbox, timeout)``: block up to *timeout* s for an inbox item and return it,
        or None on timeout (default: ``inbox.get(timeout=...)``); tests pass one that
        advances their fake clock instead of sleeping.
    spin:
        The last ``spin`` seconds (wall clock) before an event's due time are
        busy-waited, polling the inbox, instead of a blocking wait: a timed wait wakes
        up some 50-100 us late, and that lateness adds to every message published at
        the event.  0 disables it; default (None): 100e-6 s with the default ``clock``
        and ``wait``, 0 with injected ones (a fake clock does not advance while polled).
    reply_window:
        Housekeeping waits up to this long (s, wall clock) for the answers announced
        with :meth:`expect_reply` (default 5 ms).

    Housekeeping.  Python work that holds the interpreter lock for a millisecond --
    encoding the trace's rows, a garbage collection -- also holds up the Zenoh threads
    that stamp an arriving message and that send one just published (measured: a reply
    in flight during it arrived 2-3 ms late).  So while the clock runs, the automatic
    garbage collector is off (objects that exist when the run starts are collected once
    and frozen, :func:`gc.freeze`; the state is restored after the run), and both jobs
    run in budgeted slices in the slack before an event, never while an announced
    answer is still awaited: collections follow CPython's own thresholds
    (:func:`gc.get_threshold`), generation by generation.
    """

    def __init__(self, sim: Any, *, factor: float = 1.0, max_lag: float = 0.01,
                 clock: Callable[[], float] = time.monotonic,
                 wait: Callable[[queue.SimpleQueue, float], Any] | None = None, spin: float | None = None,
                 reply_window: float = DEFAULT_REPLY_WINDOW):
        validate.positive(factor, "real-time factor", kind="a positive number", type_error=ConfigurationError)
        validate.non_negative(max_lag, "max_lag", kind="a non-negative number of seconds",
                              type_error=ConfigurationError)
        if getattr(sim, "_realtime_clock", None) is not None:
            raise ConfigurationError(f"simulation {sim!r} already has a real-time clock")
        self.sim = sim
        self.env: Engine = sim.env
        self.factor = float(factor)
        self.max_lag = float(max_lag)
        self.clock = clock
        self._wait = _wait if wait is None else wait
        if spin is None:
            spin = DEFAULT_SPIN if wait is None and clock is time.monotonic else 0.0
        self.spin = validate.non_negative(spin, "spin", kind="a non-negative number of seconds",
                                          type_error=ConfigurationError)
        self.reply_window = validate.non_negative(reply_window, "reply_window",
                                                  kind="a non-negative number of seconds",
                                                  type_error=ConfigurationError)
        self.inbox: queue.SimpleQueue = queue.SimpleQueue()
        self._scale = RESOLUTION * self.factor      # wall seconds per tick
        self._start: float | None = None            # wall time of tick self._env_start
        self._env_start = 0
        self._counts = np.zeros(len(LATENESS_EDGES) - 1, dtype=np.int64)
        self._events = self._overruns = self._injections = self._late_injections = 0
        self._max = 0.0
        self._steps = self._maintained = 0
        self._pending: list = []        # injections scheduled ahead of now (timer, fn, arg)
        self._awaiting = 0              # announced answers not yet arrived
        self._quiet_at = -math.inf      # wall time after which housekeeping stops waiting for them
        self._gc_was_enabled: bool | None = None    # set while a run holds the collector
        self.collections = [0, 0, 0]    # garbage collections run in the slack, per generation
        sim._realtime_clock = self
        sim._finalizers.append(self._end_run)
        sim.realtime = True
        self.env.step = self._step

    # any thread -----------------------------------------------------------------
    def post(self, fn: Callable[..., Any], arg: Any = None) -> None:
        """From any thread: have the simulation call ``fn(arg)`` at the simulated time
        matching now on the wall clock.  Only stamps and queues; never touches SimPy."""
        self.inbox.put((self.clock(), fn, arg))

    # simulation thread ---------------------------------------------------------
    def expect_reply(self) -> None:
        """A message that may be answered was just published (simulation thread): hold
        housekeeping back until :meth:`reply_arrived` or ``reply_window`` s have passed."""
        self._awaiting += 1
        self._quiet_at = self.clock() + self.reply_window

    def reply_arrived(self) -> None:
        """An answer announced with :meth:`expect_reply` was injected (simulation thread)."""
        if self._awaiting:
            self._awaiting -= 1

    def start(self) -> None:
        """Pin simulated time *now* to wall-clock time *now* (called by the first event
        if not before; call it yourself to start the clock before the run)."""
        self._start = self.clock()
        self._env_start = self.env.now

    def wall_time(self, ticks: int) -> float:
        """Wall-clock time (s, of ``clock``) at which simulated time *ticks* is due."""
        assert self._start is not None
        return self._start + (ticks - self._env_start) * self._scale

    def sim_ticks(self, wall: float) -> int:
        """Simulated time (ticks) matching wall-clock time *wall* (s)."""
        assert self._start is not None
        return self._env_start + round((wall - self._start) / self._scale)

    def _inject(self, item) -> None:
        wall, fn, arg = item
        env = self.env
        now = env.now
        ticks = self.sim_ticks(wall)
        self._injections += 1
        if ticks < now:
            self._late_injections += 1
            ticks = now
        timer = self.sim._call_at_ticks(ticks, fn, arg=arg)
        if ticks > now:
            pending = self._pending
            pending.append((timer, fn, arg))
            if len(pending) > 64:
                self._pending = [p for p in pending if p[0].pending]

    def take_pending(self) -> list[tuple[Callable[..., Any], Any]]:
        """Injected messages scheduled after the current simulated time (a lagging
        simulation schedules a message at the simulated time of its arrival, which may
        lie beyond the stop time): withdraw them and return their ``(fn, arg)``."""
        out = [(fn, arg) for timer, fn, arg in self._pending if timer.pending]
        for timer, _, _ in self._pending:
            timer.cancel()
        self._pending = []
        return out

    def _drain(self) -> None:
        inbox = self.inbox
        while True:
            try:
                item = inbox.get_nowait()
            except queue.Empty:
                return
            self._inject(item)

    def _begin_run(self) -> None:
        if self._gc_was_enabled is None:
            self._gc_was_enabled = gc.isenabled()
            gc.disable()
            gc.collect()
            gc.freeze()

    def _end_run(self) -> None:
        """After a run (a finalizer of the simulation): the collector as it was."""
        if self._gc_was_enabled is not None:
            gc.unfreeze()
            if self._gc_was_enabled:
                gc.enable()
            self._gc_was_enabled = None

    def _step(self) -> None:
        if self._gc_was_enabled is None:
            self._begin_run()
        if self._start is None:
            self.start()
        env = self.env
        while True:
            self._drain()
            t_next = env.peek()
            if t_next == math.inf:
                raise simpy.core.EmptySchedule
            due = self.wall_time(int(t_next))
            delta = due - self.clock()
            if delta <= 0:
                break
            wait = delta - self.spin
            if delta > MAINTAIN_SLACK and self._housekeeping_due():
                if self._quiet():
                    self._housekeep(due - self.spin - HOUSEKEEPING_MARGIN)
                    continue
                wait = min(wait, self._quiet_at - (due - delta))    # wake when the reply window ends
            if wait > 0:
                item = self._wait(self.inbox, wait)
                if item is not None:
                    self._inject(item)
            # else: poll (the drain at the top of the loop) until due
        lateness = -delta
        self._events += 1
        self._counts[min(int(np.searchsorted(LATENESS_EDGES, lateness, side="right")) - 1,
                         len(self._counts) - 1)] += 1
        if lateness > self._max:
            self._max = lateness
        if lateness > self.max_lag:
            self._overruns += 1
        Engine.step(env)
        self._steps += 1
        if self._steps - self._maintained >= MAINTAIN_FORCE:    # no slack for long: memory first
            self._housekeep(math.inf)

    def _housekeeping_due(self) -> bool:
        return self._steps - self._maintained >= MAINTAIN_EVERY or gc.get_count()[0] >= gc.get_threshold()[0]

    def _quiet(self) -> bool:
        if self._awaiting and self.clock() < self._quiet_at:
            return False
        self._awaiting = 0
        return True

    def _housekeep(self, stop_at: float) -> None:
        """Encode trace rows and collect garbage until wall time *stop_at* (at least one
        chunk of rows and one collection when due)."""
        clock = self.clock

        def more() -> bool:
            return clock() < stop_at
        if self._steps - self._maintained >= MAINTAIN_EVERY:
            if self.sim.trace.maintain(more):
                self._maintained = self._steps
        if self._gc_was_enabled is None or not more():
            return
        counts, thresholds = gc.get_count(), gc.get_threshold()
        if thresholds[0] and counts[0] >= thresholds[0]:
            # CPython's rule: the oldest generation whose count passed its threshold
            gen = 2 if counts[2] >= thresholds[2] else 1 if counts[1] >= thresholds[1] else 0
            gc.collect(gen)
            self.collections[gen] += 1

    @property
    def lateness(self) -> Lateness:
        """The lateness histogram and counters so far (a snapshot)."""
        return Lateness(LATENESS_EDGES.copy(), self._counts.copy(), self._events, self._overruns, self._max,
                        self.max_lag, self._injections, self._late_injections)
