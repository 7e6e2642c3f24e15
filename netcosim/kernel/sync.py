"""Kernel synchronisation primitives: mailboxes, semaphores, monitors, events.

All blocking operations return a command to ``yield`` from a task body::

    msg = yield box.fetch()        # blocks while empty
    yield box.post(msg)            # blocks while full (bounded boxes)
    yield sem.wait(); sem.signal()
    yield mon.enter(); ...; mon.exit()
    yield ev.wait(); ev.notify(); ev.notify_all()

Waiting orders: mailboxes and semaphores serve waiters FIFO; monitors and events serve
the highest-priority waiter first (FIFO among equals).  Monitors implement priority
inheritance (``inheritance=True``, the default): a job holding a monitor runs at least
at the priority of the most urgent job waiting for it, transitively.
"""

from __future__ import annotations

from collections import deque
from typing import Any

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError
from .task import Blocking, Job


def _check_name(kind: str, name) -> str:
    return validate.name(name, f"{kind} name")


def _prio(job):
    return (job.cls, job.key, job.seq)


class _Op(Blocking):
    __slots__ = ("target", "op", "arg")

    def __init__(self, target, op, arg=None):
        self.target, self.op, self.arg = target, op, arg

    def attempt(self, job):
        return getattr(self.target, "_try_" + self.op)(job, self)

    def cancel(self, job):
        self.target._cancel(job)

    @property
    def holder(self):
        return getattr(self.target, "holder", None)


class Mailbox:
    """A FIFO message buffer called *name*, of at most *capacity* messages (``capacity=None``: unbounded).

    Raises
    ------
    ConfigurationTypeError
        If *name* is not a non-empty string.
    ConfigurationError
        If *capacity* is not a positive integer or None.

    Examples
    --------
    A sensor task posts its sample time every 10 ms after 1 ms of work; a logger task blocked
    on the mailbox gets each message at once and spends 0.5 ms on it (times in seconds):

    >>> from netcosim import Mailbox, Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> box = Mailbox("samples", capacity=4)
    >>> got = []
    >>> @cpu.periodic(period=0.010, priority=2)
    ... def sensor(ctx):
    ...     yield ctx.execute(0.001)
    ...     yield box.post(ctx.now)
    >>> @cpu.aperiodic(priority=1)
    ... def logger(ctx):
    ...     while True:
    ...         t = yield box.fetch()            # blocks while the mailbox is empty
    ...         yield ctx.execute(0.0005)
    ...         got.append((round(t, 6), round(ctx.now, 6)))
    >>> _ = logger.release()
    >>> sim.run(until=0.030)
    >>> got
    [(0.001, 0.0015), (0.011, 0.0115), (0.021, 0.0215)]

    Outside a task body (a network callback, a test), the non-blocking calls: a full
    mailbox drops and counts what it cannot hold.

    >>> latest = Mailbox("latest", capacity=1)
    >>> latest.try_post("a"), latest.try_post("b"), latest.dropped
    (True, False, 1)
    >>> latest.try_fetch(), latest.try_fetch("empty")
    ('a', 'empty')
    """

    def __init__(self, name: str = "mailbox", capacity: int | None = None):
        _check_name("mailbox", name)
        if capacity is not None:
            capacity = validate.integer(capacity, f"mailbox {name!r}: capacity", lo=1,
                                        kind="a positive integer or None", type_error=ConfigurationError)
        self.name, self.capacity = name, capacity
        self.items: deque = deque()
        self._getters: deque = deque()
        self._putters: deque = deque()  # (job, item)
        self.dropped = 0

    def __len__(self):
        return len(self.items)

    def full(self) -> bool:
        """True when a bounded mailbox holds ``capacity`` messages (never for ``capacity=None``)."""
        return self.capacity is not None and len(self.items) >= self.capacity

    # blocking ---------------------------------------------------------------
    def fetch(self) -> Blocking:
        """Command to ``yield`` from a task body: take the oldest message, blocking while the mailbox is empty.

        ``msg = yield box.fetch()``; the yield returns the message.  Blocked fetchers are
        served FIFO.
        """
        return _Op(self, "fetch")

    def post(self, item: Any) -> Blocking:
        """Command to ``yield`` from a task body: append *item*, blocking while a bounded mailbox is full.

        ``yield box.post(msg)``; a fetcher already waiting receives *item* at once.  Blocked
        posters are served FIFO.  Use :meth:`try_post` outside a task body.
        """
        return _Op(self, "post", item)

    def _try_fetch(self, job, op):
        if self.items:
            job.resume_value = self._take()
            return True
        self._getters.append(job)
        return False

    def _try_post(self, job, op):
        if self.try_post(op.arg):
            return True
        self._putters.append((job, op.arg))
        return False

    def _cancel(self, job):
        if job in self._getters:
            self._getters.remove(job)
        self._putters = deque(p for p in self._putters if p[0] is not job)

    # non-blocking (usable from anywhere, e.g. a network delivering a frame) ------
    def try_post(self, item: Any) -> bool:
        """Post *item* without blocking; returns False (and counts a drop) when full."""
        if self._getters:
            job = self._getters.popleft()
            job.node._unblock(job, item)
            return True
        if self.full():
            self.dropped += 1
            return False
        self.items.append(item)
        return True

    def try_fetch(self, default: Any = None) -> Any:
        """Fetch without blocking; returns *default* when empty."""
        if not self.items:
            return default
        return self._take()

    def _take(self):
        item = self.items.popleft()
        if self._putters:
            job, waiting = self._putters.popleft()
            self.items.append(waiting)
            job.node._unblock(job, None)
        return item


class Semaphore:
    """A counting semaphore called *name* with the initial count *value* (FIFO waiters, no priority inheritance).

    Raises
    ------
    ConfigurationTypeError
        If *name* is not a non-empty string.
    ConfigurationError
        If *value* is not a non-negative integer.

    Examples
    --------
    A semaphore guarding an A/D converter: ``lo`` takes it at t = 0 for 3 ms; ``hi``, released
    at 1 ms, preempts ``lo`` but blocks on the semaphore until ``lo`` signals at 3 ms, then
    runs 1 ms: its response time is 3 ms (times in seconds).

    >>> from netcosim import Semaphore, Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> adc = Semaphore("adc", value=1)
    >>> @cpu.aperiodic(priority=2)
    ... def lo(ctx):
    ...     yield adc.wait()
    ...     yield ctx.execute(0.003)
    ...     adc.signal()
    >>> @cpu.aperiodic(priority=1)
    ... def hi(ctx):
    ...     yield adc.wait()
    ...     yield ctx.execute(0.001)
    ...     adc.signal()
    >>> _ = lo.release()
    >>> _ = sim.call_at(0.001, hi.release)
    >>> sim.run(until=0.010)
    >>> jobs = sim.trace.jobs().set_index("task")
    >>> jobs.loc["hi", ["finish", "response_time"]].round(6).tolist(), adc.value
    ([0.004, 0.003], 1)
    """

    def __init__(self, name: str = "semaphore", value: int = 1):
        _check_name("semaphore", name)
        value = validate.integer(value, f"semaphore {name!r}: initial value", lo=0, kind="a non-negative integer",
                                 type_error=ConfigurationError)
        self.name, self.value = name, value
        self._waiters: deque = deque()

    def wait(self) -> Blocking:
        """Command to ``yield`` from a task body: take one unit, blocking while the value is 0.

        Waiters are served FIFO, without priority inheritance.
        """
        return _Op(self, "wait")

    def _try_wait(self, job, op):
        if self.value > 0:
            self.value -= 1
            return True
        self._waiters.append(job)
        return False

    def _cancel(self, job):
        if job in self._waiters:
            self._waiters.remove(job)

    def signal(self) -> None:
        """Give one unit back: wake the oldest waiter, or increment the value if nobody waits.

        Non-blocking; callable from anywhere (a task body, a handler, a network callback).
        """
        if self._waiters:
            job = self._waiters.popleft()
            job.node._unblock(job, None)
        else:
            self.value += 1


class Monitor:
    """A monitor called *name*: mutual exclusion with priority inheritance unless ``inheritance=False``.

    Raises
    ------
    ConfigurationTypeError
        If *name* is not a non-empty string or *inheritance* is not True or False.

    Examples
    --------
    Priority inversion (times in seconds): ``low`` holds the bus monitor for 4 ms from t = 0;
    ``high`` needs it at 1 ms; ``medium`` (10 ms of work, no monitor) arrives at 2 ms.  With
    priority inheritance ``low`` finishes its section at ``high``'s priority and ``high``
    waits 4 ms; without it ``medium`` runs first and ``high`` waits 14 ms.

    >>> from netcosim import Monitor, Simulation
    >>> def response_of_high(inheritance):
    ...     sim = Simulation()
    ...     cpu = sim.node("cpu")
    ...     bus = Monitor("bus", inheritance=inheritance)
    ...     def low(ctx):
    ...         yield bus.enter()
    ...         yield ctx.execute(0.004)
    ...         bus.exit()
    ...     def high(ctx):
    ...         yield bus.enter()
    ...         yield ctx.execute(0.001)
    ...         bus.exit()
    ...     def medium(ctx):
    ...         yield ctx.execute(0.010)
    ...     cpu.aperiodic(low, priority=3).release()
    ...     sim.call_at(0.001, cpu.aperiodic(high, priority=1).release)
    ...     sim.call_at(0.002, cpu.aperiodic(medium, priority=2).release)
    ...     sim.run(until=0.050)
    ...     jobs = sim.trace.jobs().set_index("task")
    ...     return round(float(jobs.loc["high", "response_time"]), 6)
    >>> response_of_high(True), response_of_high(False)
    (0.004, 0.014)
    """

    def __init__(self, name: str = "monitor", inheritance: bool = True):
        _check_name("monitor", name)
        validate.boolean(inheritance, f"monitor {name!r}: inheritance")
        self.name, self.inheritance = name, inheritance
        self.holder: Job | None = None
        self.waiters: list = []

    def enter(self) -> Blocking:
        """Command to ``yield`` from a task body: acquire the monitor, blocking while another job holds it.

        Waiters are served by priority (FIFO among equals); with ``inheritance=True`` the
        holder runs at least at the priority of its most urgent waiter.  Entering a monitor
        the job already holds raises :class:`RuntimeError`.
        """
        return _Op(self, "enter")

    def _try_enter(self, job, op):
        if self.holder is None:
            self._grant(job)
            return True
        if self.holder is job:
            raise RuntimeError(f"task {job.task.name!r} entered monitor {self.name!r} twice")
        self.waiters.append(job)
        if self.inheritance:
            self.holder.node._reprioritise(self.holder)
        return False

    def _grant(self, job):
        self.holder = job
        if job.held:
            job.held.append(self)
        else:
            job.held = [self]

    def _cancel(self, job):
        if job in self.waiters:
            self.waiters.remove(job)
            if self.holder is not None and self.inheritance:
                self.holder.node._reprioritise(self.holder)

    def exit(self) -> None:
        """Leave the monitor (must be called by the holder's task)."""
        if self.holder is None:
            raise RuntimeError(f"monitor {self.name!r} exited while not held")
        self._release_by(self.holder)

    def _release_by(self, job: Job) -> None:
        if self.holder is not job:
            return
        assert job.held, "the holder's held list names this monitor"
        job.held.remove(self)
        self.holder = None
        job.node._reprioritise(job)
        if self.waiters:
            nxt = min(self.waiters, key=_prio)
            self.waiters.remove(nxt)
            self._grant(nxt)
            nxt.node._reprioritise(nxt)
            nxt.node._unblock(nxt, None)


class ConditionVariable:
    """A kernel condition variable called *name* (TrueTime's "event"); optionally tied to a *monitor*.

    Named so as not to be confused with SimPy's ``Event`` or a plant's
    :class:`~netcosim.plant.HybridEvent`.

    With a monitor, ``wait`` must be called while holding it: the monitor is released
    during the wait and re-acquired before the waiter continues.

    Raises
    ------
    ConfigurationTypeError
        If *name* is not a non-empty string or *monitor* is neither a
        :class:`Monitor` nor None.

    Examples
    --------
    A consumer waits, inside a monitor, until a producer has set the data; the producer
    notifies at 1 ms but holds the monitor 1 ms more, so the consumer continues at 2 ms
    (times in seconds):

    >>> from netcosim import ConditionVariable, Monitor, Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> mon = Monitor("m")
    >>> ready = ConditionVariable("ready", monitor=mon)
    >>> shared = {"data": None}
    >>> woke = []
    >>> @cpu.aperiodic(priority=1)
    ... def consumer(ctx):
    ...     yield mon.enter()
    ...     while shared["data"] is None:
    ...         yield ready.wait()               # releases the monitor while waiting
    ...     woke.append((ctx.now, shared["data"]))
    ...     mon.exit()
    >>> @cpu.aperiodic(priority=2)
    ... def producer(ctx):
    ...     yield mon.enter()
    ...     yield ctx.execute(0.001)
    ...     shared["data"] = 42
    ...     ready.notify()
    ...     yield ctx.execute(0.001)
    ...     mon.exit()
    >>> _ = consumer.release(), producer.release()
    >>> sim.run(until=0.010)
    >>> woke
    [(0.002, 42)]
    """

    def __init__(self, name: str = "event", monitor: Monitor | None = None):
        _check_name("event", name)
        if monitor is not None and not isinstance(monitor, Monitor):
            raise ConfigurationTypeError(f"event {name!r}: monitor must be a Monitor or None, got {monitor!r}")
        self.name, self.monitor = name, monitor
        self._waiters: list = []

    def wait(self) -> Blocking:
        """Command to ``yield`` from a task body: wait until :meth:`notify` or :meth:`notify_all`.

        With a monitor the caller must hold it: it is released during the wait and
        re-acquired before the waiter continues (otherwise :class:`RuntimeError`).
        """
        return _Op(self, "wait")

    def _try_wait(self, job: Job, op) -> bool:
        if self.monitor is not None:
            if self.monitor.holder is not job:
                raise RuntimeError(f"task {job.task.name!r} waits on event {self.name!r} without holding "
                                   f"its monitor {self.monitor.name!r}")
            self.monitor._release_by(job)
        self._waiters.append(job)
        return False

    def _cancel(self, job):
        if job in self._waiters:
            self._waiters.remove(job)

    def _wake(self, job):
        m = self.monitor
        if m is None:
            job.node._unblock(job, None)
        elif m.holder is None:
            m._grant(job)
            job.node._unblock(job, None)
        else:
            job.blocked_on = _Op(m, "enter")
            m.waiters.append(job)
            if m.inheritance:
                m.holder.node._reprioritise(m.holder)

    def notify(self) -> bool:
        """Wake the highest-priority waiter; returns False if nobody waited."""
        if not self._waiters:
            return False
        job = min(self._waiters, key=_prio)
        self._waiters.remove(job)
        self._wake(job)
        return True

    def notify_all(self) -> int:
        """Wake every waiter, highest priority first; returns how many were waiting."""
        waiters = sorted(self._waiters, key=_prio)
        self._waiters.clear()
        for job in waiters:
            self._wake(job)
        return len(waiters)

