"""A node's local clock: local time = t·(1 + drift) + offset, stepped and slewed by task code.

TrueTime gives each kernel a clock offset and drift: the kernel's time is
``t·(1 + drift) + offset`` for simulation time *t*, and timers, periods, sleeps and
``ttCurrentTime`` are in that local time.  A :class:`LocalClock` is that mapping,
exact and monotone, plus what a real node does to its clock: a *step*
(:meth:`LocalClock.set`, ``settimeofday``) and a *slew* (:meth:`LocalClock.adjust`,
NTP's ``adjtime``: a temporary rate change that never runs the clock backwards).

Conventions:

* *Global* time is the simulation's (integer ticks of 1 ps, :mod:`netcosim.timebase`);
  *local* time is what the node's clock reads, in seconds at the API and in exact
  rational local ticks (:class:`fractions.Fraction`) inside.  The clock is piecewise
  linear: from global tick ``g0`` on, it reads ``l0 + (g - g0)·rate`` local ticks.
  ``drift`` is dimensionless (50e-6 = 50 ppm fast: one global second lasts 1.00005
  local seconds); the base rate is ``1 + drift``.
* **Rounding, once**: an event due at local time *L* happens at the first global tick at
  which the clock reads at least *L* (:meth:`LocalClock.due`, a ceiling).  The kernel
  computes every due local time from its definition (a periodic release *k* at
  ``first + k·period``, exact in local ticks) and rounds only that instant to the tick,
  so the rounding (less than one tick, always late by less than 1 ps) never accumulates.
* A step at global tick *g* changes the reading from *g* on (right-continuous); the
  timeline keeps its history, so :meth:`LocalClock.local` answers for past instants.

The kernel side (what is due when, and re-mapping it when the clock is stepped or
slewed) is :mod:`netcosim.kernel.localtime`.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from fractions import Fraction
from typing import Any, Callable

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError
from ..timebase import MAX_TICKS, TICKS_PER_SECOND, to_ticks

__all__ = ["LocalClock"]


def _check_drift(drift: Any, what: str) -> Fraction:
    if isinstance(drift, bool) or not validate.is_real(drift):
        raise ConfigurationTypeError(f"{what} must be a real number (dimensionless, 50e-6 = 50 ppm), "
                                     f"got {drift!r}")
    d = float(drift)
    if not math.isfinite(d) or d <= -1.0:
        raise ConfigurationError(f"{what}={drift!r} must be finite and > -1 (the clock's rate is 1 + drift, "
                                 f"which must stay positive; 50e-6 = 50 ppm)")
    return Fraction(d)


def _delta_ticks(delta: Any, what: str) -> int:
    """A correction of the clock (s, any sign) in ticks, rounded to the nearest tick: an
    estimate below 1 ps is a correction of 0, not an error (unlike a period)."""
    if isinstance(delta, bool) or not validate.is_real(delta):
        raise ConfigurationTypeError(f"{what} must be a real number of seconds, got {delta!r}")
    d = float(delta)
    if not math.isfinite(d) or abs(d) * TICKS_PER_SECOND > MAX_TICKS:
        raise ConfigurationError(f"{what}={delta!r} s must be finite and within netcosim's time range")
    return round(d * TICKS_PER_SECOND)


class LocalClock:
    """A node's clock: reads ``t·(1 + drift) + offset`` (s) at simulation time *t* (s).

    ``offset`` (s, any sign) is the reading at simulation time 0; ``drift`` is
    dimensionless and > -1 (50e-6: the clock gains 50 µs per second).  Give it to a node:
    ``sim.node("a", clock=LocalClock(offset=2e-3, drift=50e-6))`` (or
    ``sim.node("a", clock_offset=2e-3, clock_drift=50e-6)``); a clock serves one node.

    Reading: :meth:`local` (local seconds at a simulation instant), :meth:`global_time`
    (the simulation instant at which the clock first reads a local time), :meth:`now`.
    Changing (from task code, at the current instant): :meth:`set` steps the clock,
    :meth:`adjust` slews it.  The kernel re-maps what is pending on the node (periodic
    releases, kernel timers, sleeps) to the new timeline; ``docs/kernel.md``, "Local
    clocks", gives the rules.

    Raises
    ------
    ConfigurationTypeError
        If *offset* or *drift* is not a real number.
    ConfigurationError
        If *offset* is not finite (or beyond netcosim's time range, or a non-zero value below
        the 1 ps resolution), or *drift* is not finite or is <= -1.

    Examples
    --------
    A clock 2 ms ahead and 1000 ppm fast: a task with a 1 s local period is released every
    0.999 s of simulation time, and reads the local times 0.002, 1.002, ... s on it.

    >>> from netcosim import LocalClock, Simulation
    >>> sim = Simulation()
    >>> clock = LocalClock(offset=0.002, drift=1e-3)
    >>> cpu = sim.node("cpu", clock=clock)
    >>> @cpu.periodic(period=1.0, priority=1)
    ... def tick(ctx):
    ...     ctx.log("local", ctx.now)
    ...     yield ctx.execute(0.001)
    >>> sim.run(until=3.0)
    >>> sim.trace.jobs().release.round(9).tolist()
    [0.0, 0.999000999, 1.998001998, 2.997002997]
    >>> sim.trace.signal("cpu.tick", "local").round(9).tolist()
    [0.002, 1.002, 2.002, 3.002]
    >>> clock.local(2.0), clock.global_time(1.0)     # 2 x 1.001 + 0.002; (1 - 0.002) / 1.001
    (2.004, 0.997002997003)
    """

    __slots__ = ("drift", "offset", "_rate", "_g0", "_l0", "_rates", "_ints", "_slew_end", "_engine",
                 "_listeners", "_owner", "_fixed", "steps", "slews")

    def __init__(self, offset: float = 0.0, drift: float = 0.0):
        offset_ticks = to_ticks(offset, "LocalClock offset", allow_negative=True)
        self.offset = offset_ticks / TICKS_PER_SECOND
        self._rate = Fraction(1) + _check_drift(drift, "LocalClock drift")
        self.drift = float(drift)
        # the timeline: from global tick _g0[i] on (until _g0[i + 1]) the clock reads
        # _l0[i] + (g - _g0[i]) * _rates[i] local ticks
        self._g0: list[int] = [0]
        self._l0: list[Fraction] = [Fraction(offset_ticks)]
        self._rates: list[Fraction] = [self._rate]
        # the same segments as integers, for the kernel's per-release arithmetic (no
        # Fraction objects): (l0 numerator, l0 denominator, rate numerator, rate denominator)
        self._ints: list[tuple[int, int, int, int]] = [(offset_ticks, 1, self._rate.numerator,
                                                        self._rate.denominator)]
        self._slew_end: int | None = None     # global tick at which the slew in progress ends
        self._engine: Any = None              # the simulation's engine, once attached to a node
        self._listeners: list[Callable[[Fraction], None]] = []
        self._owner: str | None = None
        self._fixed = False                   # the ideal clock of a node created without one
        #: steps (:meth:`set`) and slews (:meth:`adjust`) so far
        self.steps = 0
        self.slews = 0

    # ------------------------------------------------------------ binding
    def _attach(self, engine: Any, owner: str, listener: Callable[[Fraction], None] | None) -> None:
        """Bind the clock to a node (its kernel re-maps pending waits via *listener*,
        called with the step in local ticks, 0 for a slew; None: the node runs on
        simulation time and the clock can be read, not changed)."""
        if self._owner is not None:
            raise ConfigurationError(f"this LocalClock already serves node {self._owner!r}; a clock serves one "
                                     f"node: give node {owner!r} its own LocalClock(...)")
        self._engine, self._owner = engine, owner
        if listener is None:
            self._fixed = True
        else:
            self._listeners.append(listener)

    def _changing(self, what: str) -> int:
        """The current global tick, once the clock may be changed (else a clear error)."""
        if self._fixed:
            raise ConfigurationError(f"node {self._owner!r} runs on simulation time (it was created without a "
                                     f"clock): {what} needs sim.node({self._owner!r}, clock=LocalClock(...)) "
                                     f"(or clock_offset=/clock_drift=)")
        return self._tick_now()

    def _tick_now(self) -> int:
        if self._engine is None:
            raise ConfigurationError("this LocalClock serves no node yet: pass it to sim.node(..., clock=...) "
                                     "before setting or reading it")
        return self._engine.now

    # ------------------------------------------------------------ the mapping (ticks)
    def _segment(self, g: int) -> int:
        g0s = self._g0
        if g >= g0s[-1]:
            return len(g0s) - 1
        return max(bisect_right(g0s, g) - 1, 0)

    def local_ticks(self, g: int) -> Fraction:
        """Exact local reading (local ticks, a Fraction) at global tick *g*."""
        i = self._segment(g)
        return self._l0[i] + (g - self._g0[i]) * self._rates[i]

    def local_nd(self, g: int) -> tuple[int, int]:
        """:meth:`local_ticks` at global tick *g* as ``(numerator, denominator)`` (not reduced)."""
        i = self._segment(g)
        ln, ld, rp, rq = self._ints[i]
        return ln * rq + (g - self._g0[i]) * rp * ld, ld * rq

    def due(self, local: Fraction | int, after: int) -> int:
        """The first global tick >= *after* at which the clock reads >= *local* (local
        ticks): the one rounding to the tick (a ceiling)."""
        return self.due_nd(local.numerator, local.denominator, after)

    def due_nd(self, num: int, den: int, after: int) -> int:
        """:meth:`due` of the local time ``num / den`` (local ticks; *den* > 0) not before the global
        tick *after*, in integers."""
        g0s, ints = self._g0, self._ints
        i = self._segment(after)
        last = len(g0s) - 1
        while True:
            ln, ld, rp, rq = ints[i]
            g0 = g0s[i]
            # the first tick g with ln/ld + (g - g0)*rp/rq >= num/den: g0 + ceil of the rest
            g = g0 - ((ln * den - num * ld) * rq // (den * ld * rp))
            start = g0 if g0 > after else after
            if g < start:
                g = start       # the clock already reads num/den at the start
            if i == last or g < g0s[i + 1]:
                return g
            i += 1

    # ------------------------------------------------------------ reading (seconds)
    def local(self, t: float | None = None) -> float:
        """The clock's reading (local s) at simulation time *t* (s; now when None)."""
        g = self._tick_now() if t is None else to_ticks(t, "LocalClock.local t")
        return float(self.local_ticks(g) / TICKS_PER_SECOND)

    def now(self) -> float:
        """The clock's reading now (local s): what ``ctx.now`` returns on its node."""
        return self.local()

    def global_time(self, local: float) -> float:
        """The simulation time (s) at which the clock first reads at least *local* (local s),
        rounded up to the tick; for times before a step forward, the instant of the step."""
        L = to_ticks(local, "LocalClock.global_time local", allow_negative=True)
        return self.due(L, 0) / TICKS_PER_SECOND

    @property
    def rate(self) -> float:
        """The clock's current rate (local s per simulation s): 1 + drift, or the slewed rate."""
        g = self._engine.now if self._engine is not None else 0
        return float(self._rates[self._segment(g)])

    # ------------------------------------------------------------ changing the clock
    def _cut(self, g: int) -> None:
        """Drop the timeline from *g* on (a slew's planned end included)."""
        i = bisect_right(self._g0, g)     # segments starting after g go; one starting at g too
        if i and self._g0[i - 1] == g:
            i -= 1
        del self._g0[i:], self._l0[i:], self._rates[i:], self._ints[i:]

    def _append(self, g: int, local: Fraction, rate: Fraction) -> None:
        self._g0.append(g)
        self._l0.append(local)
        self._rates.append(rate)
        self._ints.append((local.numerator, local.denominator, rate.numerator, rate.denominator))

    def _remaining_slew(self, g: int) -> Fraction:
        """Local ticks the slew in progress has still to gain at *g* (0 without one)."""
        if self._slew_end is None or g >= self._slew_end:
            return Fraction(0)
        i = self._segment(g)
        return (self._slew_end - g) * (self._rates[i] - self._rate)

    def set(self, local: float) -> float:
        """Step the clock now so it reads *local* (s); return the step (s, + forward).

        TrueTime's ``ttCurrentTime(newTime)``.  A slew in progress is abandoned.  What is
        pending on the node is re-mapped (absolute waits fire when the clock reaches them,
        at once if the step skipped them; relative sleeps keep their remaining length).
        """
        L = Fraction(to_ticks(local, "LocalClock.set local", allow_negative=True))
        g = self._changing("set()")
        return self._step(g, L - self.local_ticks(g))

    def step(self, delta: float) -> float:
        """Step the clock now by *delta* (s, + forward; rounded to the tick); return the step (s)."""
        d = _delta_ticks(delta, "LocalClock.step delta")
        return self._step(self._changing("step()"), Fraction(d))

    def _step(self, g: int, step: Fraction) -> float:
        L = self.local_ticks(g) + step
        self._cut(g)
        self._append(g, L, self._rate)
        self._slew_end = None
        self.steps += 1
        for listener in self._listeners:
            listener(step)
        return float(step / TICKS_PER_SECOND)

    def adjust(self, delta: float, *, over: float) -> float:
        """Slew the clock: gain *delta* (s, + forward) over the next *over* s, then run at
        ``1 + drift`` again; return what the slew replaced had still to gain (s).

        NTP's ``adjtime``: the rate is ``(1 + drift)·(1 + delta/over)`` meanwhile, so the
        clock never jumps; *delta* > -*over* keeps it running forwards.  *over* is counted
        on the clock at its base rate and rounded to the tick once (the slew lasts
        ``round(over / (1 + drift))`` ticks of simulation time); the gain is exactly
        *delta* rounded to the tick (an estimate below 1 ps is a gain of 0).  A new
        adjust replaces the one in progress; ``adjust(0, over=...)`` cancels it.
        """
        d = _delta_ticks(delta, "LocalClock.adjust delta")
        over_ticks = to_ticks(over, "LocalClock.adjust over")
        if over_ticks <= 0:
            raise ConfigurationError(f"LocalClock.adjust over={over!r} s must be positive")
        g = self._changing("adjust()")
        span = max(1, round(over_ticks / self._rate))       # global ticks
        rate = self._rate + Fraction(d, span)
        if rate <= 0:
            raise ConfigurationError(f"LocalClock.adjust(delta={delta!r}, over={over!r}): the clock would stop "
                                     f"or run backwards; a slew needs delta > -over")
        left = self._remaining_slew(g)
        here = self.local_ticks(g)
        self._cut(g)
        self._append(g, here, rate)
        self._append(g + span, here + span * rate, self._rate)
        self._slew_end = g + span
        self.slews += 1
        for listener in self._listeners:
            listener(Fraction(0))
        return float(left / TICKS_PER_SECOND)

    def slew(self, rate_correction: float, *, duration: float) -> float:
        """Run the clock at ``(1 + drift)·(1 + rate_correction)`` (dimensionless, 100e-6 =
        100 ppm faster) for *duration* s of its base rate: ``adjust(rate_correction *
        duration, over=duration)``."""
        rc = _check_drift(rate_correction, "LocalClock.slew rate_correction")
        return self.adjust(float(rc) * validate.finite(duration, "LocalClock.slew duration"), over=duration)

    def __repr__(self) -> str:
        who = f" of node {self._owner!r}" if self._owner else ""
        return f"<LocalClock{who} offset={self.offset!r} s drift={self.drift!r}>"
