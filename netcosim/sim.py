"""The :class:`Simulation`: one SimPy environment, named random streams, the trace.

Time inside the environment is integer ticks of 1 ps (see :mod:`netcosim.timebase`);
``Simulation.now`` reports seconds.
"""

from __future__ import annotations

import inspect
from typing import TYPE_CHECKING, Any, Callable

import numpy as np
import simpy

from . import validate
from .clock import DISPATCH, MAINTAIN_EVERY, NORMAL, URGENT, Engine, RealtimeEngine, Timer, stable_hash  # noqa: F401 (re-exported)
from .errors import ConfigurationError, ConfigurationTypeError, SimulationFailedError
from .timebase import TICKS_PER_SECOND, to_seconds, to_ticks
from .trace import Trace

if TYPE_CHECKING:
    from .kernel.node import Node
    from .plant import PlantInstance

class Simulation:
    """A co-simulation: nodes, networks and plants sharing one SimPy clock.

    Parameters
    ----------
    seed:
        Root seed. Each component draws from ``rng(name)``, a stream derived from the
        seed and the component's name, so adding a component never changes the draws
        of the others; same seed, same results, bit for bit.
    realtime:
        Run against the wall clock (for hardware-in-the-loop): one simulated second
        takes ``factor`` wall-clock seconds, counted from the first :meth:`run` (the
        set-up before it -- building nodes, plants, connecting remotes -- does not make
        the first events late).  ``True`` or ``False`` exactly.
    strict:
        In real-time mode, raise when an event is processed more than ``max_lag``
        seconds late; otherwise record the lag in ``Simulation.lags``.
        ``factor``, ``strict`` and ``max_lag`` are checked even when ``realtime`` is
        off (a bad value is refused, not ignored).

    Memory: a simulation and its components refer to each other (reference cycles), so
    dropping the last reference to a finished simulation does not free it at once (its
    traces included); Python's cyclic garbage collector does, eventually.  A loop that
    runs many simulations in one process (a sweep) calls ``gc.collect()`` after each run,
    or every few runs, to keep memory flat (``benchmarks/sweep_memory.py`` measures it).

    Examples
    --------
    Two tasks under EDF: ``fast`` (1 ms every 4 ms) has the earlier deadline at t = 0, so
    ``slow`` (2 ms every 10 ms) waits 1 ms; times in seconds.

    >>> from netcosim import Simulation
    >>> sim = Simulation(seed=1)
    >>> cpu = sim.node("cpu", scheduler="edf")
    >>> @cpu.periodic(period=0.010, name="slow")
    ... def slow(ctx):
    ...     yield ctx.execute(0.002)
    >>> @cpu.periodic(period=0.004, name="fast")
    ... def fast(ctx):
    ...     yield ctx.execute(0.001)
    >>> sim.run(until=0.015)
    >>> jobs = sim.trace.to_pandas("jobs")
    >>> jobs[jobs.task == "slow"]["response_time"].round(6).tolist()
    [0.003, 0.002]
    """

    def __init__(self, seed: int = 0, *, realtime: bool = False, factor: float = 1.0,
                 strict: bool = True, max_lag: float = 0.01):
        validate.integer(seed, "seed", lo=0, kind="a non-negative integer", type_error=ConfigurationError)
        self.seed = int(seed)
        # The real-time parameters are checked whether or not realtime is on: a bad value is
        # a bug in the caller even when it would not be used.
        validate.boolean(realtime, "realtime")
        validate.positive(factor, "real-time factor", kind="a positive number", type_error=ConfigurationError)
        validate.non_negative(max_lag, "max_lag", kind="a non-negative number of seconds",
                              type_error=ConfigurationError)
        validate.boolean(strict, "strict")
        if realtime:
            self.env: Engine = RealtimeEngine(factor, strict, max_lag)
        else:
            self.env = Engine()
        self.realtime = realtime
        self._paced = False         # realtime: the wall clock is pinned at the first run()
        self.trace = Trace(clock=lambda: self.env.now)
        from .kernel.tables import register  # the kernel's schedule and jobs tables, empty until a node runs
        register(self.trace)
        self.env.maintain = self.trace.maintain
        self._rngs: dict[str, np.random.Generator] = {}
        self._names: dict[str, Any] = {}
        self.nodes: dict[str, Any] = {}
        self.plants: dict[str, Any] = {}
        self.networks: dict[str, Any] = {}
        self._finalizers: list[Callable[[], None]] = []
        self._failure: BaseException | None = None
        self._failure_time = 0.0
        self._stepping = 0  # > 0 while task code runs (kernel dispatch must then be deferred)

    # Time ------------------------------------------------------------------
    @property
    def now(self) -> float:
        """Current simulated time in seconds."""
        return self.env.now / TICKS_PER_SECOND

    @property
    def now_ticks(self) -> int:
        """Current simulated time in integer ticks (1 tick = :data:`~netcosim.timebase.RESOLUTION` s)."""
        return self.env.now

    @property
    def lags(self) -> list[tuple[float, float]]:
        """Real-time mode: (simulated time, lag in s) of every event processed late."""
        return list(getattr(self.env, "lags", []))

    def call_at(self, t: float, fn: Callable, priority: int = NORMAL, arg: Any = Timer.NOARG) -> Timer:
        """Call ``fn()`` (``fn(arg)`` if *arg* is given) at absolute time *t* (s).

        Returns a :class:`~netcosim.clock.Timer` whose ``cancel()`` withdraws the call.
        ``priority`` orders calls of the same instant (:data:`~netcosim.clock.NORMAL`
        by default; smaller first).
        """
        ticks = to_ticks(t, "call_at time")
        if ticks < self.env.now:
            raise ConfigurationError(f"call_at time t={t!r} s lies before now={self.now} s (cannot schedule "
                                     f"in the past)")
        validate.callable_(fn, "call_at fn", kind="callable (called when the time comes)")
        return Timer.call(self.env, ticks - self.env.now, fn, arg, priority)

    def call_in(self, delay: float, fn: Callable, priority: int = NORMAL, arg: Any = Timer.NOARG) -> Timer:
        """Call ``fn()`` (``fn(arg)`` if *arg* is given) *delay* seconds from now; *priority* as
        for :meth:`call_at`."""
        delay_ticks = to_ticks(delay, "call_in delay")
        validate.callable_(fn, "call_in fn", kind="callable (called when the time comes)")
        return Timer.call(self.env, delay_ticks, fn, arg, priority)

    def call_at_ticks(self, ticks: int, fn: Callable, priority: int = NORMAL, arg: Any = Timer.NOARG) -> Timer:
        """:meth:`call_at` with the instant in integer ticks (for components that compute in ticks).

        *ticks* must be an ``int`` (not a float, not a bool) and *fn* callable; *priority*
        and *arg* as for :meth:`call_at`.  The
        framework's own components call the unchecked :meth:`_call_at_ticks` (once per
        frame or job: no per-event check).
        """
        ticks = validate.integer(ticks, "call_at_ticks ticks", kind="an integer number of ticks",
                                 fraction_error=ConfigurationTypeError)
        validate.callable_(fn, "call_at_ticks fn", kind="callable (called when the time comes)")
        return self._call_at_ticks(int(ticks), fn, priority, arg)

    def _call_at_ticks(self, ticks: int, fn: Callable, priority: int = NORMAL, arg: Any = Timer.NOARG) -> Timer:
        """:meth:`call_at_ticks` without the checks on *ticks* and *fn* (the framework's hot path)."""
        env = self.env
        now = env.now
        if ticks < now:
            raise ConfigurationError(f"cannot schedule in the past: {to_seconds(ticks)} s < now {self.now} s")
        return Timer.call(env, ticks - now, fn, arg, priority)

    def call_in_ticks(self, delay_ticks: int, fn: Callable, priority: int = NORMAL, arg: Any = Timer.NOARG
                      ) -> Timer:
        """:meth:`call_in` with the delay *delay_ticks* in integer ticks (for components that compute
        in ticks): calls *fn* (with *arg*, at *priority*) then; unchecked."""
        return Timer.call(self.env, delay_ticks, fn, arg, priority)

    def timeout(self, seconds: float) -> simpy.Timeout:
        """A SimPy timeout of *seconds* (for user processes written against SimPy)."""
        return self.env.timeout(to_ticks(seconds, "timeout"))

    def process(self, generator) -> simpy.Process:
        """Start *generator* as a SimPy process on this simulation's environment; returns the process.

        Inside it, time is SimPy's: integer ticks (use :meth:`timeout` for a delay in seconds).
        """
        if not inspect.isgenerator(generator):
            raise ConfigurationTypeError(f"process needs a generator (call the generator function), got {generator!r}")
        return self.env.process(generator)  # type: ignore[arg-type]  # SimPy types the events it yields

    # Randomness ------------------------------------------------------------
    def rng(self, name: str) -> np.random.Generator:
        """The random stream called *name* (created on first use, then shared)."""
        try:
            g = self._rngs.get(name)
        except TypeError:               # unhashable: refused below
            g = None
        if g is None:
            if not isinstance(name, str):
                raise ConfigurationTypeError(f"random stream name must be a string, got {name!r}")
            ss = np.random.SeedSequence(entropy=self.seed, spawn_key=(stable_hash(name),))
            g = self._rngs[name] = np.random.Generator(np.random.PCG64(ss))
        return g

    # Components ------------------------------------------------------------
    def _check_new_name(self, name: str) -> None:
        validate.name(name, "component name", type_error=ConfigurationError)
        if name in self._names:
            raise ConfigurationError(f"a component called {name!r} already exists")

    def _register(self, name: str, obj: Any) -> None:
        self._check_new_name(name)
        self._names[name] = obj

    def node(self, name: str, scheduler: Any = "fixed_priority", *, context_switch: float = 0.0,
             speed: float = 1.0, cores: int = 1, scheduling: str = "partitioned",
             migration: float = 0.0, clock: Any = None, clock_offset: float | None = None,
             clock_drift: float | None = None) -> "Node":
        """Add a real-time kernel called *name* (one CPU unless ``cores`` > 1).

        ``scheduler`` is a policy instance or one of ``"fixed_priority"``,
        ``"rate_monotonic"``, ``"deadline_monotonic"``, ``"edf"``.  ``context_switch``
        is the CPU time (s, at speed 1) of one context switch; ``speed`` scales every
        execution time (2.0 = twice as fast; changeable during the run on a one-core node:
        ``node.set_speed``).  ``cores`` (1..64): the number of CPUs;
        ``scheduling``: ``"partitioned"`` (each task pinned with ``core=k``, TrueTime's
        affinity) or ``"global"`` (one ready queue, jobs migrate); ``migration``: the cost
        (s, at speed 1) of resuming a job on another core under global scheduling
        (:mod:`netcosim.kernel.multicore`).  ``clock``: a
        :class:`~netcosim.kernel.localclock.LocalClock` (or ``clock_offset`` s and
        ``clock_drift``, dimensionless, 50e-6 = 50 ppm: TrueTime's kernel block parameters);
        periods, offsets, timers, sleeps and ``ctx.now`` are then in the node's local time
        (``docs/kernel.md``, "Local clocks").  Without one the node runs on simulation time.
        """
        from .kernel.multicore import MAX_CORES, SCHEDULING, MulticoreNode
        from .kernel.node import Node
        n = validate.integer(cores, f"node {name!r}: cores", lo=1, hi=MAX_CORES)
        validate.choice(scheduling, f"node {name!r}: scheduling", SCHEDULING)
        self._check_new_name(name)
        clocked = {"clock": clock, "clock_offset": clock_offset, "clock_drift": clock_drift}
        if n == 1 and scheduling == "partitioned":
            if migration != 0:
                validate.non_negative(migration, f"node {name!r}: migration")
                raise ConfigurationError(f"node {name!r}: migration={migration!r} s needs scheduling='global' "
                                         f"and several cores")
            node = Node(self, name, scheduler, context_switch=context_switch, speed=speed, **clocked)
        else:
            node = MulticoreNode(self, name, scheduler, cores=n, scheduling=scheduling, migration=migration,
                                 context_switch=context_switch, speed=speed, **clocked)
        self._register(name, node)
        self.nodes[name] = node
        return node

    def plant(self, system: Any, x0: Any, *, name: str | None = None, integrator: Any = None,
              params: Any = None, disturbance: Callable[[float], Any] | None = None,
              log_interval: float | None = None, log: str = "io") -> "PlantInstance":
        """Add a continuous system integrated lazily alongside the discrete world.

        *system* is a :class:`~netcosim.plant.ContinuousSystem`, or a python-control
        ``StateSpace``, ``TransferFunction`` or ``NonlinearIOSystem`` (converted by
        :func:`netcosim.plant.pycontrol.from_control`).  The other arguments (*x0*, *name*,
        *integrator*, *params*, *disturbance*, *log_interval*, *log*) are those of
        :class:`netcosim.plant.PlantInstance`; returns the instance.
        """
        from .plant import PlantInstance, from_control, is_control_system
        if name is None:    # the system's own name, else plant0, plant1, ... ('' is refused as a name)
            name = getattr(system, "name", None) or f"plant{len(self.plants)}"
        self._check_new_name(name)      # before the plant is built (an unhashable name failed in it)
        if is_control_system(system):
            system = from_control(system)
        p = PlantInstance(self, name, system, x0, integrator=integrator, params=params,
                          disturbance=disturbance, log_interval=log_interval, log=log)
        self._register(name, p)
        self.plants[name] = p
        return p

    def add_finalizer(self, fn: Callable[[], None]) -> None:
        """Call ``fn()`` at the end of every :meth:`run`, to bring a component up to the stop time.

        After a failed run, finalizers are called at the failure instant, except the
        failing component's own (a bound method of the object that raised), and an
        exception they raise is attached to the original failure as a note.
        """
        validate.callable_(fn, "finalizer", kind="callable with no arguments")
        self._finalizers.append(fn)

    # Running ---------------------------------------------------------------
    @property
    def failure(self) -> BaseException | None:
        """The exception that ended a failed :meth:`run` (None while the simulation is healthy)."""
        return self._failure

    def run(self, until: float) -> None:
        """Advance the simulation to *until* seconds (absolute).

        At the end the plants are brought up to the stop time.  If anything raises
        during the run (a task body, a plant, a network), the exception propagates
        exactly once, with the note ``netcosim: run failed at t = ... s``; every plant
        except the failing one is first brought to the failure instant (the failing
        plant keeps its last finite state), and the traces keep everything recorded so
        far.  The simulation is then dead: a later ``run()`` raises
        :class:`~netcosim.errors.SimulationFailedError` naming the original failure
        (jobs were cut off mid-flight, so continuing would be wrong); build a new
        :class:`Simulation` to run again.
        """
        if self._failure is not None:
            f = self._failure
            raise SimulationFailedError(
                f"this simulation failed at t = {self._failure_time:.9f} s with {type(f).__name__}: {f}; "
                f"its traces stay readable, but it cannot continue: build a new Simulation") from f
        stop = to_ticks(until, "until")
        if stop < self.env.now:
            raise ConfigurationError(f"until={until!r} s lies before now={self.now} s")
        try:
            if stop == self.env.now:
                pass            # nothing to advance (SimPy's run refuses until == now)
            elif self.realtime:
                if not self._paced:
                    sync = getattr(self.env, "sync", None)   # a HIL engine paces itself
                    if sync is not None:
                        sync()          # pin simulated time to the wall clock now
                    self._paced = True
                self.env.run(until=stop)
            else:
                self.env.run_until(stop)
        except BaseException as exc:
            self._fail(exc)
            raise
        for fn in self._finalizers:
            try:
                fn()
            except BaseException as exc:
                self._fail(exc)
                raise
        self.trace.maintain()

    def _fail(self, exc: BaseException) -> None:
        """Mark the simulation dead, note the time on *exc*, bring the other components to now.

        A plant whose own integration raised keeps its last finite state (its finalizer
        skips it, see :attr:`PlantInstance.failure <netcosim.plant.PlantInstance.failure>`).
        """
        self._failure = exc
        self._failure_time = self.now
        exc.add_note(f"netcosim: run failed at t = {self.now:.9f} s")
        for fn in self._finalizers:
            try:
                fn()
            except Exception as other:
                owner = getattr(fn, "__self__", fn)
                exc.add_note(f"netcosim: bringing {getattr(owner, 'name', owner)!r} to the failure "
                             f"instant also failed: {type(other).__name__}: {other}")
