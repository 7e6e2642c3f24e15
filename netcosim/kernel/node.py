"""A node: one CPU with a real-time kernel (TrueTime's kernel block) -- its public face.

The user API is here: creating periodic and aperiodic tasks and interrupt handlers,
kernel timers and triggers, analog I/O channels and network sends.  The kernel itself
is in the node's base classes (``netcosim/kernel/state.py`` says which part owns
what): :mod:`~netcosim.kernel.dispatcher` (releases, ready queue, preemption, context
switches, priority inheritance), :mod:`~netcosim.kernel.interpreter` (running a job's
body) and :mod:`~netcosim.kernel.overrun` (deadline and budget timers).  Periodic
releases belong to :mod:`~netcosim.kernel.releases` (``node._releases``).
"""

from __future__ import annotations

from types import MethodType
from typing import Any, Callable

from .. import validate
from ..clock import Rearmable, Timer
from ..energy import Battery, check_cpu_model
from ..errors import ConfigurationError, ConfigurationTypeError, NotConnectedError
from ..recorder import Sink
from ..timebase import MAX_SECONDS, MAX_TICKS, RESOLUTION, TICKS_PER_SECOND, to_ticks
from .dispatcher import Dispatcher
from .io import AnalogIn, AnalogOut
from .localclock import LocalClock
from .policies import EDF, make_policy, own_choose
from .power import CoresMeter, CpuMeter, NodePower, change_speed, power_off
from .ready import ReadyQueue
from .releases import Releases
from .servers import CBS, TBS, ServedEDF, Server
from .tables import STATE_CODES, jobs_table, schedule_table
from .task import DEFAULT_MAX_PENDING, Job, Task
from .timers import KernelTimer, Trigger


def _check_target(target: Any, what: str) -> None:
    """The task a timer or trigger releases must be a task (``node.aperiodic(...)``)."""
    if not isinstance(target, Task):
        raise ConfigurationTypeError(f"{what} target must be a task (from node.aperiodic or node.periodic), "
                                     f"got {target!r}")


class Node(Dispatcher):
    """A CPU with a scheduler.  Create with :meth:`Simulation.node`.

    Parameters
    ----------
    sim : Simulation
        The simulation the node belongs to (its environment, trace and random streams).
    name : str
        The node's name, unique in *sim* (names its tasks' random streams and trace rows).
    scheduler : str or policy
        A policy instance or one of ``"fixed_priority"`` (default), ``"rate_monotonic"``,
        ``"deadline_monotonic"``, ``"edf"``.
    context_switch : float
        CPU time (s, at speed 1) of one context switch; 0 (default): none.
    speed : float
        CPU speed, positive and finite (1: nominal, 2.0: twice as fast); every execution
        time and context switch is divided by it (:attr:`speed`, :meth:`set_speed`).
    clock, clock_offset, clock_drift
        A :class:`~netcosim.kernel.localclock.LocalClock`, or its ``clock_offset`` (s) and
        ``clock_drift`` (dimensionless, 50e-6 = 50 ppm) to build one (not both forms); then
        periods, timers, sleeps and ``ctx.now`` are in the node's local time.  All None
        (default): the node runs on simulation time.

    Raises
    ------
    ConfigurationError
        If *scheduler* names no policy, *context_switch* is negative, not finite or below
        the 1 ps resolution (also once divided by *speed*), *speed* is not positive and finite
        (or so slow that 1 ps of work lasts beyond the time range), both a *clock* and
        *clock_offset* / *clock_drift* are given, the clock already serves another node, or
        *clock_offset* / *clock_drift* is a number a
        :class:`~netcosim.kernel.localclock.LocalClock` refuses.
    ConfigurationTypeError
        If *scheduler* is neither a policy nor a name, *context_switch*, *speed*,
        *clock_offset* or *clock_drift* is not a number, or *clock* is not a
        :class:`~netcosim.kernel.localclock.LocalClock`.

    Examples
    --------
    A node at twice the nominal speed with a 100 µs context switch: 2 ms of work (at speed 1)
    takes 1 ms, plus one context switch of 100 µs / 2, so the job's response time is 1.05
    ms (times in seconds).

    >>> from netcosim import Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu", scheduler="fixed_priority", speed=2.0, context_switch=100e-6)
    >>> @cpu.periodic(period=0.010, priority=1)
    ... def ctrl(ctx):
    ...     yield ctx.execute(0.002)
    >>> sim.run(until=0.010)
    >>> cpu, sim.trace.jobs().response_time.round(6).tolist()
    (<Node cpu fixed_priority>, [0.00105])
    """

    #: False: one CPU (a :class:`~netcosim.kernel.multicore.MulticoreNode` has several)
    multicore = False

    def __init__(self, sim, name: str, scheduler: Any = "fixed_priority", *, context_switch: float = 0.0,
                 speed: float = 1.0, clock: LocalClock | None = None, clock_offset: float | None = None,
                 clock_drift: float | None = None):
        self.sim = sim
        self.name = name
        self.policy = make_policy(scheduler)
        self._choose = own_choose(self.policy)  # None: the dispatcher's inlined key rule
        cs = to_ticks(context_switch, f"node {name!r} context_switch")
        self.context_switch = context_switch
        # speed and energy state, one attribute (see kernel.power.NodePower); the context
        # switch's work in ticks at speed 1
        self._pw = NodePower(1.0, cs)
        self._tick_scale, self._cs_ticks = self._scaled(speed)
        self._pw.speed = float(speed)
        self.tasks: dict[str, Task] = {}
        #: the node's bandwidth servers by name (:meth:`cbs`, :meth:`tbs`)
        self.servers: dict[str, Any] = {}
        self.ready = ReadyQueue()
        self.running: Job | None = None
        self._loaded: Job | None = None
        self._in_cs: bool = False
        self._np_job: Job | None = None  # non-preemptible job interrupted by a handler
        self._dispatch_pending: bool = False
        self._seq: int = 0
        self._ain: dict[int, AnalogIn] = {}
        self._aout: dict[int, AnalogOut] = {}
        self.interfaces: dict[str, Any] = {}
        self._env: Any = sim.env  # SimPy types `now` as int | float; here it is always integer ticks
        # one event object, re-armed for every dispatch request (at most one pending)
        self._dispatch_event = Rearmable(sim.env)
        if self._choose is not None:  # the policy picks among the ready jobs: its own dispatch path
            self._dispatch = self._dispatch_chosen  # type: ignore[method-assign]
        self._dispatch_callbacks: list[Callable] = [self._dispatch]
        self._segment_cb = self._segment_done  # one bound method for every segment timer
        # ...and one callback list for a re-armed one: SimPy only replaces a fired event's list
        self._segment_cbs: list[Callable[[Any], None]] = [self._segment_cb]
        # a segment timer that has fired (out of SimPy's queue), re-armed for the next segment
        # instead of creating one; cancelled timers may still sit in the queue and are never kept
        self._spare_timer: Timer | None = None
        self._sched: Sink = schedule_table(sim.trace).rows
        self._releases = Releases(self)  # the periodic releases (kernel.releases owns them)
        jobs = jobs_table(sim.trace)
        self._jobrec: Sink = jobs.rows
        jobs.providers.append(self._unfinished_rows)
        if clock is not None or clock_offset is not None or clock_drift is not None:
            self._use_clock(clock, clock_offset, clock_drift)

    #: the kernel on the node's local clock (:mod:`~netcosim.kernel.localtime`), None
    #: without one.  A class attribute, set on the instance only for a node with a clock:
    #: a node's attributes are near CPython 3.11's limit of 30 per shared-key instance
    #: dict, beyond which every attribute read in the kernel's per-job path gets slower
    #: (two more attributes on every node cost 7 % per job).
    _local: Any = None

    @property
    def clock(self) -> LocalClock:
        """The node's clock (:class:`~netcosim.kernel.localclock.LocalClock`): its own when
        created with one; else an ideal clock (local = simulation time) to read, not set."""
        local = self._local
        if local is not None:
            return local.clock
        ideal = LocalClock()
        ideal._attach(self._env, self.name, None)
        return ideal

    def _use_clock(self, clock, offset, drift) -> None:
        """Run the node on a local clock: periods, timers, sleeps and ``ctx.now`` are local
        (:mod:`~netcosim.kernel.localtime`).  A node without one keeps the kernel's own code
        path, untouched."""
        if clock is not None:
            if offset is not None or drift is not None:
                raise ConfigurationError(f"node {self.name!r}: pass either clock=LocalClock(...) or "
                                         f"clock_offset=/clock_drift=, not both")
            if not isinstance(clock, LocalClock):
                raise ConfigurationTypeError(f"node {self.name!r}: clock must be a LocalClock(offset=..., "
                                             f"drift=...), got {clock!r}")
        else:
            clock = LocalClock(offset=0.0 if offset is None else offset, drift=0.0 if drift is None else drift)
        from .localtime import LocalReleases, LocalTime, release_local
        self._local = LocalTime(self, clock)
        self._releases = LocalReleases(self._local)  # type: ignore[assignment]
        self._release = MethodType(release_local, self)  # type: ignore[method-assign]

    # ------------------------------------------------------------------ speed and energy
    def _scaled(self, speed: Any) -> tuple[float, int]:
        """``(ticks per second of CPU work, context-switch ticks)`` at *speed*, checked."""
        name = self.name
        validate.positive(speed, f"node {name!r}: speed")
        if RESOLUTION / speed > MAX_SECONDS:
            raise ConfigurationError(f"node {name!r}: speed={speed!r} is so slow that 1 ps of CPU time would "
                                     f"last beyond netcosim's time range, {MAX_SECONDS:.6g} s")
        cs = self._pw.cs_work
        context_switch = self.context_switch
        if cs / speed > MAX_TICKS:
            raise ConfigurationError(f"node {name!r}: context_switch={context_switch!r} s at speed {speed!r} "
                                     f"lasts beyond netcosim's time range, {MAX_SECONDS:.6g} s")
        cs_ticks = int(round(cs / speed))
        if cs and not cs_ticks:
            raise ConfigurationError(
                f"node {name!r}: context_switch={context_switch!r} s at speed {speed!r} is "
                f"{context_switch / speed!r} s, below the time resolution {RESOLUTION} s")
        return TICKS_PER_SECOND / speed, cs_ticks

    @property
    def speed(self) -> float:
        """CPU speed (1: nominal): execution and context switches progress at ``speed`` times
        simulated time.  Settable at run time (``node.speed = s``, :meth:`set_speed`)."""
        return self._pw.speed

    @speed.setter
    def speed(self, speed: float) -> None:
        self.set_speed(speed)

    def set_speed(self, speed: float) -> None:
        """Change the CPU speed now (DVS), e.g. from task code: ``ctx.node.set_speed(0.5)``.

        *speed* must be a positive finite number.  The remaining work of the running
        segment, of preempted segments and of a context switch under way is rescaled at
        this instant (work = ticks * speed, kept exactly across changes: see
        :mod:`netcosim.kernel.power`); later ``execute`` requests and context switches use
        the new speed.  The CPU's power meter, if any, changes now too.  On a multicore
        node every core changes (one speed per node, as TrueTime's one per kernel).
        """
        pw = self._pw
        old = pw.speed
        scale, cs_ticks = self._scaled(speed)
        speed = float(speed)
        if speed == old:
            return
        self._tick_scale, self._cs_ticks = scale, cs_ticks
        pw.speed = speed
        change_speed(self, old, speed)
        if pw.cpu_meter is not None:
            pw.cpu_meter.update()

    def set_power_model(self, model: Any) -> None:
        """Meter the CPU's power with *model* (``model.power(busy, speed) -> W``:
        :class:`~netcosim.energy.ConstantPower`, TrueTime's, or :class:`~netcosim.energy.DvsPower`)
        from now on; the energy shows in :attr:`energy` and the ``energy`` table.  On a
        multicore node the power is summed over the cores when ``model.per_core`` is true
        (``DvsPower``; a model without the attribute), drawn once otherwise (``ConstantPower``):
        see :class:`~netcosim.kernel.power.CoresMeter`."""
        model = check_cpu_model(model, f"node {self.name!r}")
        pw = self._pw
        if pw.cpu_meter is not None:
            pw.cpu_meter.model = model
            pw.cpu_meter.update()
            return
        pw.cpu_meter = CoresMeter(self, model) if self.multicore else CpuMeter(self, model)

    def set_battery(self, battery: Any) -> Any:
        """Supply this node (its CPU and its radios) from *battery* (a :class:`~netcosim.energy.Battery`);
        returns it.  When it runs empty the node stops (``docs/kernel.md``, "Energy and batteries")."""
        if not isinstance(battery, Battery):
            raise ConfigurationTypeError(f"node {self.name!r}: set_battery needs a netcosim.energy.Battery, "
                                         f"got {battery!r}")
        if self._pw.battery is not None:
            raise ConfigurationError(f"node {self.name!r} already has a battery")
        for iface in self.interfaces.values():       # e.g. 802.11b's shared idle-slot clock refuses
            check = getattr(iface.network, "_require_per_station", None)
            if check is not None:
                check(f"a battery on node {self.name!r}")
        self._pw.battery = battery
        battery._attach(self)
        return battery

    @property
    def battery(self) -> Any:
        """The node's :class:`~netcosim.energy.Battery` (None: an unlimited supply)."""
        return self._pw.battery

    @property
    def _battery(self) -> Any:      # what a power meter draws from (netcosim.energy.PowerMeter)
        return self._pw.battery

    @property
    def _meters(self) -> list:      # the node's power meters (netcosim.energy.PowerMeter)
        return self._pw.meters

    @property
    def energy(self) -> float:
        """Energy (J) used so far by the node's metered consumers (CPU and radios)."""
        return sum(m.energy for m in self._pw.meters)

    @property
    def powered(self) -> bool:
        """False once the node's battery ran empty (the node then does nothing)."""
        return self._pw.powered

    @property
    def releases_lost(self) -> int:
        """Releases dropped because the node was off (its battery empty)."""
        return self._pw.releases_lost

    def _release_lost(self, task: Task, t: int) -> None:
        """``_release`` of a node whose battery is empty: nothing runs; counted."""
        self._pw.releases_lost += 1
        return None

    def _power_off(self) -> None:
        power_off(self)

    # ------------------------------------------------------------------ tasks
    def _add_task(self, body, kind, name, server=None, core=None, **kw) -> Task:
        if core is not None and core != 0:
            raise ConfigurationError(f"node {self.name!r} has one core (core 0); got core={core!r}: create it "
                                     f"with sim.node(..., cores=N) for more")
        if server is not None and (not isinstance(server, Server) or server.node is not self):
            raise ConfigurationTypeError(f"node {self.name!r}: server must be a server of this node "
                                         f"(node.cbs(...) or node.tbs(...)), got {server!r}")
        task = Task(self, body, name=name, kind=kind, **kw)
        if task.name in self.tasks:
            raise ConfigurationError(f"node {self.name!r} already has a task called {task.name!r}")
        if kind == "handler":
            validate.finite(task.priority, f"handler {task.name!r}: priority", value_error=ConfigurationTypeError)
        else:
            self.policy.validate(task)
        if kind != "handler" and self.policy.static:
            task.static_key = self.policy.key(Job(task, -1, 0))
        if server is not None:
            server.attach(task)
        if self._local is not None:
            from .localtime import LocalTaskContext
            task.ctx = LocalTaskContext(task)
        self.tasks[task.name] = task
        self._trace(task, "idle")
        return task

    def periodic(self, body: Callable | None = None, *, period: float, offset: float = 0.0, priority=None,
                 deadline: float | None = None, wcet: float | None = None, name: str | None = None,
                 preemptible: bool = True, on_busy: str = "queue", on_deadline_miss=None,
                 on_budget_overrun=None, max_pending: int | None = DEFAULT_MAX_PENDING,
                 on_queue_full: str = "drop", server=None, core: int | None = None):
        """Add a periodic task released at ``offset + k*period`` (s).  Usable as a decorator.

        ``body``: the task's code, a generator function ``body(ctx)`` (a plain function runs
        in zero time and must return None); None: return a decorator taking the body.
        ``name``: the task's name, unique on the node (default: the body's ``__name__``).
        ``period`` (s, > 0) and ``offset`` (s, >= 0, from the task's creation).
        ``priority``: small = high (fixed-priority policy; ignored by RM/DM/EDF).
        ``deadline``: relative deadline (s; default: the period).  ``wcet``: execution
        budget (s) per job, None: none; a job exceeding it is a budget overrun.
        ``preemptible``: False runs each job to its end once started (handlers still
        interrupt it).  ``on_busy``: what a release does while the previous job is still
        active, ``"queue"`` (default) or ``"skip"`` (dropped, counted in ``task.skipped``).
        ``on_deadline_miss``, ``on_budget_overrun``: a callable ``f(job)`` called at the
        instant of the miss or overrun, or ``"kill"`` to abort the job; None (default):
        only recorded.  ``max_pending`` (jobs,
        None: unbounded) and ``on_queue_full`` (``"drop"`` or ``"error"``): the bound on
        queued jobs (:class:`~netcosim.kernel.task.Task`).  ``server``: a server of this
        node (:meth:`cbs`, :meth:`tbs`) that serves the task.  ``core``: the core the task is
        pinned to on a partitioned multicore node (default 0; :mod:`~netcosim.kernel.multicore`).
        """
        def make(fn):
            task = self._add_task(fn, "periodic", name, server=server, core=core, priority=priority,
                                  period=period,
                                  offset=offset,
                                  deadline=deadline, wcet=wcet, preemptible=preemptible, on_busy=on_busy,
                                  on_deadline_miss=on_deadline_miss, on_budget_overrun=on_budget_overrun,
                                  max_pending=max_pending, on_queue_full=on_queue_full)
            self._releases.arm(task)
            return task
        return make if body is None else make(body)

    def aperiodic(self, body: Callable | None = None, *, priority=None, deadline: float | None = None,
                  wcet: float | None = None, name: str | None = None, preemptible: bool = True,
                  on_busy: str = "queue", on_deadline_miss=None, on_budget_overrun=None,
                  max_pending: int | None = DEFAULT_MAX_PENDING, on_queue_full: str = "drop", server=None,
                  core: int | None = None):
        """Add a task whose jobs are released by ``task.release()``, triggers, timers or messages.

        ``body``, ``name``, ``priority``, ``preemptible``, ``on_busy``, ``on_deadline_miss``,
        ``on_budget_overrun``: as for :meth:`periodic`.
        ``deadline``: relative deadline (s) of each job; ``wcet``: execution budget (s);
        ``max_pending``, ``on_queue_full``: the bound on queued jobs, as for :meth:`periodic`;
        ``server``: a server of this node that serves the task, and ``core``, as for :meth:`periodic`.
        """
        def make(fn):
            return self._add_task(fn, "aperiodic", name, server=server, core=core, priority=priority,
                                  deadline=deadline, wcet=wcet,
                                  preemptible=preemptible, on_busy=on_busy, on_deadline_miss=on_deadline_miss,
                                  on_budget_overrun=on_budget_overrun, max_pending=max_pending,
                                  on_queue_full=on_queue_full)
        return make if body is None else make(body)

    def handler(self, body: Callable | None = None, *, priority: float = 0, name: str | None = None,
                deadline: float | None = None, core: int | None = None):
        """Add an interrupt handler: it beats every task; handlers are ordered by priority.

        ``body``: the handler's code, a generator function ``body(ctx)`` (or a plain function
        returning None); None: return a decorator taking the body.  ``name``: unique on the
        node (default: the body's ``__name__``).  ``priority``: a finite number, small = high,
        ordering the handlers among themselves (default 0).
        ``deadline``: relative deadline (s) of each activation.  ``core``: the core it runs
        on, on a partitioned multicore node (default 0).
        """
        def make(fn):
            return self._add_task(fn, "handler", name, core=core, priority=priority, deadline=deadline)
        return make if body is None else make(body)

    # ---------------------------------------------------------------- servers
    def cbs(self, budget: float, period: float, *, hard: bool = False, name: str | None = None) -> CBS:
        """A constant-bandwidth server (TrueTime's ``ttCreateCBS``): *budget* s of CPU per
        *period* s, soft (``hard=False``: the deadline is postponed when the budget runs out)
        or hard (the server's tasks wait for the next period).  Needs an EDF node; attach
        tasks with ``server=`` or :meth:`CBS.attach <netcosim.kernel.servers.CBS.attach>`
        (:mod:`netcosim.kernel.servers` states the rules).  ``name``: the server's name,
        unique on the node (default ``"cbs<n>"``, n the number of servers so far)."""
        return self._add_server(CBS, name, budget=budget, period=period, hard=hard)

    def tbs(self, utilization: float, *, name: str | None = None) -> TBS:
        """A total-bandwidth server of *utilization* Us (0 < Us <= 1): a job reaching it at r
        gets the deadline ``max(d_last, r) + wcet / Us``.  Needs an EDF node; its tasks need
        a ``wcet``.  ``name``: the server's name, unique on the node (default ``"tbs<n>"``,
        n the number of servers so far)."""
        return self._add_server(TBS, name, utilization=utilization)

    def _add_server(self, cls, name, **kw):
        if name is None:
            name = f"{cls.__name__.lower()}{len(self.servers)}"
        validate.name(name, "server name")
        if name in self.servers:
            raise ConfigurationError(f"node {self.name!r} already has a server called {name!r}")
        if not isinstance(self.policy, EDF):
            raise ConfigurationError(f"node {self.name!r}: servers run under EDF (as TrueTime's); this node "
                                     f"schedules with {self.policy.name!r}: create it with scheduler='edf'")
        server = cls(self, name, **kw)
        if not isinstance(self.policy, ServedEDF):
            self._set_policy(ServedEDF([]))
        self.servers[name] = server
        policy: Any = self.policy
        policy.servers.append(server)
        return server

    def _set_policy(self, policy) -> None:
        """Schedule with *policy* from now on (its own ``choose``, if any, takes over dispatching)."""
        self.policy = policy
        self._choose = own_choose(policy)
        if self._choose is not None:
            self._dispatch = self._dispatch_chosen  # type: ignore[method-assign]
        else:
            self.__dict__.pop("_dispatch", None)
        self._dispatch_callbacks[:] = [self._dispatch]

    def timer(self, target: Task, *, at: float | None = None, period: float | None = None) -> "KernelTimer":
        """Release *target* at absolute time ``at`` (s), then every ``period`` s if given
        (local time on a node with a clock)."""
        _check_target(target, "timer")
        if self._local is not None:
            from .localtime import LocalKernelTimer
            return LocalKernelTimer(self, target, at, period)  # type: ignore[return-value]
        return KernelTimer(self, target, at, period)

    def trigger(self, target: Task, *, min_interval: float = 0.0) -> "Trigger":
        """An external trigger releasing *target*; edges closer than ``min_interval`` s are ignored."""
        _check_target(target, "trigger")
        return Trigger(self, target, min_interval)

    # --------------------------------------------------------------- analog I/O
    def analog_in(self, channel: int) -> AnalogIn:
        """Analog input *channel* of this node (connect it to a plant output port)."""
        try:
            ch = self._ain.get(channel)
        except TypeError:           # unhashable: AnalogIn refuses it, naming it
            ch = None
        if ch is None:
            ch = AnalogIn(self, channel)
            self._ain[ch.channel] = ch
        return ch

    def analog_out(self, channel: int) -> AnalogOut:
        """Analog output *channel* of this node (connect it to a plant input port)."""
        try:
            ch = self._aout.get(channel)
        except TypeError:           # unhashable: AnalogOut refuses it, naming it
            ch = None
        if ch is None:
            ch = AnalogOut(self, channel)
            self._aout[ch.channel] = ch
        return ch

    # ---------------------------------------------------------------- networks
    def send(self, dst, payload=None, size_bits=None, *, priority=None, network=None):
        """Send a message through a network interface of this node.

        ``dst``: the receiver, a node name, a node, an interface or
        :data:`~netcosim.network.BROADCAST`.  ``payload``: any Python object, delivered as is
        (its size on the wire is ``size_bits``, not measured).
        ``size_bits``: the message size in bits (the network's default when None);
        ``priority``: the MAC priority (small = high; CAN's identifier order), default the
        interface's.  ``network`` names the interface when the node has several.
        Returns the :class:`~netcosim.network.frame.Message`.
        """
        if not self.interfaces:
            raise NotConnectedError(f"node {self.name!r} has no network interface; attach it to a network first")
        if network is None:
            if len(self.interfaces) > 1:
                raise ConfigurationError(f"node {self.name!r} is on several networks {sorted(self.interfaces)}; "
                                         f"pass network=")
            iface = next(iter(self.interfaces.values()))
        else:
            key = getattr(network, "name", network)
            try:
                iface = self.interfaces[key]
            except (KeyError, TypeError):       # TypeError: an unhashable network=
                raise ConfigurationError(f"node {self.name!r} is not on network {key!r}; "
                                         f"it is on {sorted(self.interfaces)}") from None
        return iface.send(dst, payload, size_bits, priority=priority)

    # ------------------------------------------------------------------ kernel
    def _trace(self, task: Task, state: str) -> None:
        if task.state != state:
            task.state = state
            self._sched.append((self._env.now, task, STATE_CODES[state]))

    def _unfinished_rows(self) -> list[tuple]:
        """Rows for jobs still active or queued now (finish = NaN); added when the table is read."""
        now = self._env.now
        rows = []
        for task in self.tasks.values():
            jobs = ([task.active] if task.active is not None else []) + list(task.pending)
            for job in jobs:
                done = job.exec_done
                if job.state == "running" and job.seg_timer is not None:
                    done += now - job.seg_start
                rows.append((task, job.index, job.release, job.start, None, done,
                             job.abs_deadline is not None and now > job.abs_deadline, job.budget_overrun, False))
        return rows

    def __repr__(self):
        return f"<Node {self.name} {self.policy.name}>"
