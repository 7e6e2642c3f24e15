"""Energy: power models of a CPU and of a radio, power meters, batteries.

Units: power in W, energy in J, time in s at the API (integer ticks of 1 ps inside).

**Power models** are plain objects; the simulator asks them for the power of a state and
integrates it exactly (the power is constant between two state changes):

* a CPU model has ``power(busy: bool, speed: float) -> W`` (:class:`ConstantPower`,
  TrueTime's; :class:`DvsPower`, power growing with speed and load), and may say
  ``per_core``: whether a multicore node draws it once per core (True, the default for a
  model without the attribute) or once for the whole kernel (False);
* a radio model has ``power(state: str, tx_w: float) -> W`` with *state* ``"tx"``
  (transmitting, *tx_w* the radiated power in W), ``"rx"`` (locked onto a frame) or
  ``"listen"`` (idle listening) (:class:`RadioPower`).

**Meters.** A :class:`PowerMeter` holds one consumer's power (a node's CPU, one radio
interface), integrates it piecewise (``E += P * dt`` at every change: no scan of any table
at the end), reports ``energy`` at any time and draws from the node's :class:`Battery`.
Each change is a row of the trace table ``energy``: ``time`` (s), ``node``, ``source``
(``"cpu"`` or the network's name; ``"battery"`` for the mark), ``event`` (``"power"``: the
consumer's power changed; ``"empty"``: the battery ran empty), ``power`` (W, from then on),
``energy`` (J used by that source so far), ``battery`` (J left; NaN without a battery).

**Battery.** ``Battery(capacity)`` (J) attached to a node (``node.set_battery``) supplies
its CPU and its radios: the level falls by the integral of their summed power, saturates
at 0 (and never exceeds the capacity), and when it reaches 0 -- at the instant predicted
exactly from the summed power, rounded to the nearest tick -- the node stops
(``docs/kernel.md``, "Energy and batteries").
"""

from __future__ import annotations

import math
import warnings
from typing import Any, Callable

from . import validate
from .clock import Timer
from .errors import BatteryEmptyWarning, ConfigurationError, ConfigurationTypeError
from .timebase import MAX_TICKS, TICKS_PER_SECOND

#: the columns of the ``energy`` table as stored (time in ticks) and reported (time in s)
ENERGY_COLUMNS = ("time", "node", "source", "event", "power", "energy", "battery")


# ------------------------------------------------------------------------- CPU models
class ConstantPower:
    """TrueTime's kernel power: *watts* whatever the CPU does and whatever its speed.

    ``P = watts`` (W, finite, >= 0).  The simplest model: energy grows linearly with time.
    On a multicore node it is the whole kernel's power, drawn once (TrueTime's reading).

    Raises
    ------
    ConfigurationTypeError
        If *watts* is not a number.
    ConfigurationError
        If *watts* is negative or not finite.

    Examples
    --------
    A CPU drawing 10 mW whatever it does uses 10 mW x 2 s = 0.02 J in 2 s:

    >>> from netcosim import ConstantPower, Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> cpu.set_power_model(ConstantPower(0.010))
    >>> sim.run(until=2.0)
    >>> round(cpu.energy, 9)
    0.02
    """

    #: the power of a whole kernel, not of each core (kernel.power.CoresMeter)
    per_core = False

    def __init__(self, watts: float):
        self.watts = validate.non_negative(watts, "ConstantPower: watts (W)")

    def power(self, busy: bool, speed: float) -> float:
        """``watts`` (W), whatever *busy* and *speed*."""
        return self.watts

    def __repr__(self) -> str:
        return f"ConstantPower({self.watts!r})"


class DvsPower:
    """A CPU whose power depends on its load and its speed (dynamic voltage/frequency scaling).

    ``P = static + busy * dynamic * speed**exponent`` (W): ``static`` (W, >= 0) is drawn
    always (leakage, memory, clock tree: the idle power), ``dynamic`` (W, >= 0) is the
    extra power of a busy CPU at speed 1, ``busy`` is 1 while a job or a context switch
    runs and 0 otherwise.  The CMOS switching power is ``C V**2 f``; with the supply
    voltage scaled in proportion to the clock frequency (``V ∝ f``, the usual DVS
    assumption, valid well above the threshold voltage) it grows as ``f**3`` -- the
    default ``exponent = 3``.  A job of work ``c`` (s at speed 1) then costs
    ``dynamic * c * speed**2`` J of dynamic energy: halving the speed quarters it, while the
    static power is paid over the doubled time.

    On a multicore node it is each core's power: the node draws
    ``N * static + n_busy * dynamic * speed**exponent`` with ``n_busy`` of its ``N`` cores
    busy (each core of a chip leaks and switches on its own).

    Raises
    ------
    ConfigurationTypeError
        If *static*, *dynamic* or *exponent* is not a number.
    ConfigurationError
        If one of them is negative or not finite.

    Examples
    --------
    A control task of 4 ms of work (at speed 1) every 10 ms, for 1 s, on a CPU with 1 mW of
    static and 100 mW of dynamic power.  At speed 1 the CPU is busy 0.4 s:
    ``0.001 x 1 + 0.1 x 0.4 = 0.041`` J.  At speed 0.5 it is busy 0.8 s at
    ``0.1 x 0.5**3`` W: ``0.001 + 0.0125 x 0.8 = 0.011`` J, the dynamic energy quartered.

    >>> from netcosim import DvsPower, Simulation
    >>> def energy(speed):
    ...     sim = Simulation()
    ...     cpu = sim.node("cpu", speed=speed)
    ...     cpu.set_power_model(DvsPower(static=0.001, dynamic=0.1))
    ...     @cpu.periodic(period=0.010, priority=1)
    ...     def ctrl(ctx):
    ...         yield ctx.execute(0.004)
    ...     sim.run(until=1.0)
    ...     return round(cpu.energy, 9)
    >>> energy(1.0), energy(0.5)
    (0.041, 0.011)
    """

    #: one core's power: a multicore node sums it over its cores (kernel.power.CoresMeter)
    per_core = True

    def __init__(self, static: float = 0.0, dynamic: float = 1.0, exponent: float = 3.0):
        self.static = validate.non_negative(static, "DvsPower: static (W)")
        self.dynamic = validate.non_negative(dynamic, "DvsPower: dynamic (W at speed 1)")
        self.exponent = validate.non_negative(exponent, "DvsPower: exponent")

    def power(self, busy: bool, speed: float) -> float:
        """Power (W) of the CPU busy (True) or idle at *speed* (see the class docstring)."""
        if busy:
            return self.static + self.dynamic * speed ** self.exponent
        return self.static

    def __repr__(self) -> str:
        return f"DvsPower(static={self.static!r}, dynamic={self.dynamic!r}, exponent={self.exponent!r})"


# ----------------------------------------------------------------------- radio model
class RadioPower:
    """Power drawn by a radio (W) by state.

    * transmitting: ``tx_elec + P_out / efficiency``, ``P_out`` the radiated power (W, from
      the station's transmit power in dBm at the frame's start), ``tx_elec`` (W, >= 0) the
      transmitter electronics, ``efficiency`` in (0, 1] the power amplifier's;
    * receiving (locked onto a frame, addressed to it or not): ``rx`` (W, >= 0);
    * listening (on, nothing locked: idle listening): ``listen`` (W, >= 0).

    The defaults are of the order of a 2.4 GHz 802.15.4 transceiver (CC2420 at 3 V: about
    52 mW transmitting at 0 dBm, 56 mW receiving or listening): ``tx_elec = 0.049``,
    ``efficiency = 0.3``, ``rx = listen = 0.056``.  Idle listening costs as much as
    receiving, which is what dominates a radio's energy at low traffic.
    :meth:`truetime` is TrueTime's model: the radiated power while transmitting, nothing
    otherwise.

    Raises
    ------
    ConfigurationTypeError
        If a parameter is not a number.
    ConfigurationError
        If *tx_elec*, *rx* or *listen* is negative or not finite, or *efficiency* is not in
        (0, 1].

    Examples
    --------
    The default model radiating 1 mW (0 dBm): ``0.049 + 0.001 / 0.3`` W while transmitting,
    56 mW receiving or listening.

    >>> from netcosim import RadioPower
    >>> radio = RadioPower()
    >>> round(radio.power("tx", 1e-3), 6), radio.power("rx", 0.0), radio.power("listen", 0.0)
    (0.052333, 0.056, 0.056)

    Given to a wireless network (``set_energy_model``), with TrueTime's model: one 800-bit
    message at 250 kbit/s and 0 dBm costs its sender 1 mW x the frame's 3.744 ms on the air
    (936 bits: 800 + 88 of MAC overhead + 48 of PHY synchronisation header); the receiver
    pays for the acknowledgement it sends (40 + 48 bits, 0.352 ms).  Energies in µJ:

    >>> from netcosim import IEEE802154, Simulation
    >>> sim = Simulation()
    >>> net = IEEE802154(sim, "zigbee", data_rate=250e3, tx_power_dbm=0.0)
    >>> a, b = sim.node("a"), sim.node("b")
    >>> _ = net.attach(a, position=(0.0, 0.0)), net.attach(b, position=(5.0, 0.0))
    >>> net.set_energy_model(RadioPower.truetime())
    >>> @a.aperiodic(priority=1)
    ... def send(ctx):
    ...     ctx.send("b", "sample", 800)
    ...     yield ctx.execute(1e-6)
    >>> _ = send.release()
    >>> sim.run(until=0.1)
    >>> round(a.energy * 1e6, 6), round(b.energy * 1e6, 6)
    (3.744, 0.352)
    """

    def __init__(self, tx_elec: float = 0.049, efficiency: float = 0.3, rx: float = 0.056,
                 listen: float = 0.056):
        self.tx_elec = validate.non_negative(tx_elec, "RadioPower: tx_elec (W)")
        eff = validate.positive(efficiency, "RadioPower: efficiency")
        if eff > 1.0:
            raise ConfigurationError(f"RadioPower: efficiency must be in (0, 1], got {efficiency!r}")
        self.efficiency = eff
        self.rx = validate.non_negative(rx, "RadioPower: rx (W)")
        self.listen = validate.non_negative(listen, "RadioPower: listen (W)")

    @classmethod
    def truetime(cls) -> "RadioPower":
        """TrueTime's radio energy: ``P = P_out`` while transmitting, 0 otherwise."""
        return cls(tx_elec=0.0, efficiency=1.0, rx=0.0, listen=0.0)

    def power(self, state: str, tx_w: float) -> float:
        """Power (W) in *state* (``"tx"``, ``"rx"``, ``"listen"``), radiating *tx_w* W when ``"tx"``."""
        if state == "tx":
            return self.tx_elec + tx_w / self.efficiency
        if state == "rx":
            return self.rx
        return self.listen

    def __repr__(self) -> str:
        return (f"RadioPower(tx_elec={self.tx_elec!r}, efficiency={self.efficiency!r}, rx={self.rx!r}, "
                f"listen={self.listen!r})")


def check_cpu_model(model: Any, what: str) -> Any:
    """*model* if it has ``power(busy, speed)`` giving a finite power >= 0 (W) idle and busy at
    speed 1, and a boolean ``per_core`` if any; *what* names its owner (e.g. ``"node 'cpu'"``)
    in the error."""
    if not callable(getattr(model, "power", None)):
        raise ConfigurationTypeError(f"{what}: a power model needs power(busy, speed) -> W "
                                     f"(e.g. ConstantPower(0.01), DvsPower(...)), got {model!r}")
    for busy in (False, True):
        validate.non_negative(model.power(busy, 1.0), f"{what}: {model!r}.power({busy}, 1.0) (W)")
    per_core = getattr(model, "per_core", True)
    if not isinstance(per_core, bool):
        raise ConfigurationTypeError(f"{what}: {model!r}.per_core must be True (power of one core) or False "
                                     f"(of the whole kernel), got {per_core!r}")
    return model


def check_radio_model(model: Any, what: str) -> Any:
    """*model* if it has ``power(state, tx_w)`` giving finite powers >= 0 (W) in the states
    ``"tx"``, ``"rx"`` and ``"listen"``; *what* names its owner in the error."""
    if not callable(getattr(model, "power", None)):
        raise ConfigurationTypeError(f"{what}: a radio power model needs power(state, tx_w) -> W "
                                     f"(e.g. RadioPower(), RadioPower.truetime()), got {model!r}")
    for state in ("tx", "rx", "listen"):
        validate.non_negative(model.power(state, 1e-3), f"{what}: {model!r}.power({state!r}, 0.001) (W)")
    return model


# ------------------------------------------------------------------------- meters
def energy_table(trace: Any) -> Any:
    """The ``energy`` table of *trace* (created on first call; columns :data:`ENERGY_COLUMNS`)."""
    return trace.table("energy", ENERGY_COLUMNS, categorical=("node", "source", "event"),
                       transform=_energy_frame, keeps_categories=True)


def _energy_frame(df):
    df["time"] = df["time"].astype(float) / TICKS_PER_SECOND
    return df


class BareOwner:
    """The owner of a meter without a kernel node (a bare radio station driven from Python):
    its ``name`` and ``sim``, no battery."""

    def __init__(self, sim: Any, name: str):
        self.sim = sim
        self.name = name
        self._meters: list[PowerMeter] = []
        self._battery = None

    @property
    def energy(self) -> float:
        """Energy (J) its meters used so far."""
        return sum(m.energy for m in self._meters)


class PowerMeter:
    """One consumer's power (W), constant between changes, and its energy (J) so far.

    ``owner`` is the kernel node it belongs to (its battery, if any, supplies it);
    ``source`` names it in the ``energy`` table.  :meth:`set` changes the power now.
    """

    __slots__ = ("owner", "source", "power", "t0", "e0", "battery", "off", "_rows", "_env")

    def __init__(self, owner: Any, source: str, power: float):
        self.owner = owner
        self.source = source
        self._env = owner.sim.env
        self._rows = energy_table(owner.sim.trace).rows
        self.power = 0.0
        self.t0 = self._env.now
        self.e0 = 0.0
        self.off = False
        self.battery: Battery | None = None
        owner._meters.append(self)
        bat = owner._battery
        if bat is not None:
            bat._add(self)
        self.set(power)

    def energy_at(self, now: int) -> float:
        """Energy (J) used up to tick *now* (>= the last change)."""
        return self.e0 + self.power * (now - self.t0) / TICKS_PER_SECOND

    @property
    def energy(self) -> float:
        """Energy (J) used so far."""
        return self.energy_at(self._env.now)

    def set(self, power: float) -> None:
        """The consumer draws *power* (W) from now on (nothing once its battery is empty)."""
        if self.off:
            return
        now = self._env.now
        bat = self.battery
        if bat is not None:
            bat._advance(now)
        self.e0 = self.energy_at(now)
        self.t0 = now
        self.power = power
        level = math.nan
        if bat is not None:
            bat._rearm()
            level = bat._level
        self._rows.append((now, self.owner.name, self.source, "power", power, self.e0, level))

    def stop(self) -> None:
        """Draw nothing from now on, for good (the battery is empty)."""
        self.set(0.0)
        self.off = True


class Battery:
    """An energy store of ``capacity`` J (finite, >= 0), full at the start unless ``initial``
    (J, in [0, capacity]) says otherwise.

    Attach it with ``node.set_battery(battery)``: the node's CPU and radios draw from it.
    ``level`` (J) is exact at any instant (the summed power is constant between changes);
    ``empty_at`` (s) is when it ran empty (None before).  ``on_empty`` callbacks
    ``fn(battery)`` run at that instant, after the node stopped.

    Raises
    ------
    ConfigurationTypeError
        If *capacity* or *initial* is not a number.
    ConfigurationError
        If *capacity* or *initial* is negative or not finite, or *initial* exceeds *capacity*.

    Examples
    --------
    A 1 J battery feeding a CPU that draws 0.5 W runs empty at 1 J / 0.5 W = 2 s; the node
    stops then, with a :class:`~netcosim.errors.BatteryEmptyWarning`.

    >>> import warnings
    >>> from netcosim import Battery, ConstantPower, Simulation
    >>> sim = Simulation()
    >>> cpu = sim.node("cpu")
    >>> cpu.set_power_model(ConstantPower(0.5))
    >>> battery = cpu.set_battery(Battery(capacity=1.0))
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     sim.run(until=3.0)
    >>> battery.empty_at, battery.level, cpu.powered
    (2.0, 0.0, False)
    >>> print(caught[0].message)
    node 'cpu': battery (1 J) empty at t = 2 s; the node stops (no jobs run, its radios neither send nor receive)
    """

    def __init__(self, capacity: float, initial: float | None = None):
        self.capacity = validate.non_negative(capacity, "Battery: capacity (J)")
        if initial is None:
            initial = self.capacity
        self.initial = validate.non_negative(initial, "Battery: initial (J)")
        if self.initial > self.capacity:
            raise ConfigurationError(f"Battery: initial={initial!r} J exceeds capacity={capacity!r} J")
        self._level = self.initial
        self._t0 = 0
        self._meters: list[PowerMeter] = []
        self._timer: Timer | None = None
        self._env: Any = None
        self.node: Any = None
        self.empty_at: float | None = None
        self.on_empty: list[Callable[[Battery], None]] = []

    def _attach(self, node: Any) -> None:
        if self.node is not None:
            raise ConfigurationError(f"Battery is already attached to node {self.node.name!r}")
        self.node = node
        self._env = node.sim.env
        self._t0 = self._env.now
        for m in node._meters:
            self._add(m)
        self._rearm()
        if self._level <= 0.0:      # an empty battery stops the node at once
            self._env_timer(0)

    def _add(self, meter: PowerMeter) -> None:
        if self._env is not None:
            self._advance(self._env.now)
        meter.battery = self
        self._meters.append(meter)
        self._rearm()

    @property
    def power(self) -> float:
        """Summed power (W) drawn now."""
        return math.fsum(m.power for m in self._meters)

    @property
    def level(self) -> float:
        """Energy left (J), in [0, capacity]."""
        if self._env is None:
            return self._level
        return self._level_at(self._env.now)

    @property
    def empty(self) -> bool:
        """True once the battery ran empty."""
        return self.empty_at is not None

    def _level_at(self, now: int) -> float:
        lv = self._level - self.power * (now - self._t0) / TICKS_PER_SECOND
        return min(max(lv, 0.0), self.capacity)

    def _advance(self, now: int) -> None:
        self._level = self._level_at(now)
        self._t0 = now

    def _rearm(self) -> None:
        """Re-predict the instant the level reaches 0 with the summed power from now on."""
        if self._env is None or self.empty_at is not None:
            return
        p = self.power
        if self._timer is not None:
            self._timer.cancel()
            self._timer = None
        if p <= 0.0:
            return
        ticks = self._level / p * TICKS_PER_SECOND
        if ticks > MAX_TICKS - self._env.now:
            return
        self._env_timer(int(round(ticks)))

    def _env_timer(self, delay: int) -> None:
        self._timer = Timer.call(self._env, delay, self._ran_empty)

    def _ran_empty(self) -> None:
        self._timer = None
        env = self._env
        now = env.now
        self._level = 0.0
        self._t0 = now
        self.empty_at = now / TICKS_PER_SECOND
        node = self.node
        for m in self._meters:
            m.stop()
        energy_table(node.sim.trace).rows.append((now, node.name, "battery", "empty", 0.0,
                                                  node.energy, 0.0))
        warnings.warn(f"node {node.name!r}: battery ({self.capacity:g} J) empty at t = {self.empty_at:.9g} s; "
                      f"the node stops (no jobs run, its radios neither send nor receive)",
                      BatteryEmptyWarning, stacklevel=2)
        node._power_off()
        for fn in self.on_empty:
            fn(self)

    def __repr__(self) -> str:
        return f"Battery(capacity={self.capacity!r} J, level={self.level!r} J)"
