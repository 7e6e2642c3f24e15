"""A plant's ports: :class:`OutputPort` (read) and :class:`InputPort` (write, zero-order hold)."""

from __future__ import annotations

from typing import Any, Protocol, Sequence

import numpy as np

from ..errors import ConfigurationTypeError, NetcosimError

__all__ = ["OutputPort", "InputPort", "UnknownPortError"]


class _Plant(Protocol):
    """What a port uses of its plant (:class:`~netcosim.plant.instance.PlantInstance`)."""

    name: str

    def output_now(self) -> np.ndarray: ...

    def set_input(self, index: Any, value: Any, label: str = ...) -> None: ...


class OutputPort:
    """Read side of a plant: samples ``h(t, x, u)`` (selected outputs) at ``now``.

    Made by :meth:`PlantInstance.output <netcosim.plant.instance.PlantInstance.output>`:
    ``plant`` the plant; ``index`` the outputs it selects (an int: one, read as a float;
    a list or a slice: several, read as an array); ``label`` its name in messages (the
    output's name, or e.g. ``"outputs"`` for all).

    Examples
    --------
    A task samples the DC servo ``1000 / (s (s + 1))`` every 50 ms while 1 V is held on
    its input from rest; the angle (rad) is ``1000 (t - 1 + e^-t)``:

    >>> import math
    >>> from netcosim import Simulation
    >>> from netcosim.plants.dc_servo import DCServo
    >>> sim = Simulation()
    >>> servo = sim.plant(DCServo(), [0.0, 0.0])
    >>> y = servo.output("y")
    >>> y
    <OutputPort servo.y>
    >>> samples = []
    >>> @sim.node("cpu").periodic(period=0.05, priority=1, name="sampler")
    ... def sampler(ctx):
    ...     samples.append(round(y.read(), 6))
    ...     yield ctx.execute(0.001)
    >>> servo.input("u").write(1.0)
    >>> sim.run(until=0.2)
    >>> samples
    [0.0, 1.229425, 4.837418, 10.707976]
    >>> [round(1000 * (t - 1 + math.exp(-t)), 6) for t in (0.0, 0.05, 0.1, 0.15)]
    [0.0, 1.229425, 4.837418, 10.707976]
    """

    def __init__(self, plant: _Plant, index, label: str):
        self.plant, self.index, self.label = plant, index, label

    def read(self):
        """The selected outputs at the current simulated time: a float for one output, else a copy of
        the array (the plant's units)."""
        y = self.plant.output_now()
        if type(self.index) is int:
            return float(y[self.index])
        v = y[self.index]
        return float(v) if np.ndim(v) == 0 else v.copy()

    def __repr__(self):
        return f"<OutputPort {self.plant.name}.{self.label}>"


class InputPort:
    """Write side of a plant: the value written is held (ZOH) until the next write.

    Made by :meth:`PlantInstance.input <netcosim.plant.instance.PlantInstance.input>`:
    ``plant`` the plant; ``index`` the inputs it selects (an int: one; a list or a slice:
    several); ``label`` its name in messages (the input's name, or ``"inputs"`` for all).

    Examples
    --------
    The lag ``dx/dt = -x + u`` (1 s time constant) under ``u = 1`` for 0.5 s, then
    ``u = 0`` for 0.5 s: each value is held until the next write, so
    ``x(1) = (1 - e^-0.5) e^-0.5``:

    >>> import math
    >>> from netcosim import Simulation
    >>> from netcosim.plant import ContinuousSystem
    >>> lag = ContinuousSystem(f=lambda t, x, u, p: -x + u, states=["x"], inputs=["u"], name="lag")
    >>> sim = Simulation()
    >>> plant = sim.plant(lag, [0.0])
    >>> u = plant.input("u")
    >>> u
    <InputPort lag.u>
    >>> u.write(1.0)
    >>> sim.run(until=0.5)
    >>> u.write(0.0)
    >>> sim.run(until=1.0)
    >>> round(plant.output("x").read(), 6), round((1 - math.exp(-0.5)) * math.exp(-0.5), 6)
    (0.238651, 0.238651)
    """

    def __init__(self, plant: _Plant, index, label: str):
        self.plant, self.index, self.label = plant, index, label

    def write(self, value) -> None:
        """Hold *value* on the selected inputs from now until the next write (zero-order hold; the plant's units)."""
        self.plant.set_input(self.index, value, self.label)

    def __repr__(self):
        return f"<InputPort {self.plant.name}.{self.label}>"


class UnknownPortError(NetcosimError, KeyError, IndexError):
    """A plant has no such input or output (a name it does not have, an index out of
    range); the message lists the ones it has.  A :class:`KeyError` and an
    :class:`IndexError`, as before.

    Examples
    --------
    >>> from netcosim import Simulation
    >>> from netcosim.plants.dc_servo import DCServo
    >>> servo = Simulation().plant(DCServo(), [0.0, 0.0])
    >>> servo.output("angle")
    Traceback (most recent call last):
      ...
    netcosim.plant.ports.UnknownPortError: plant 'servo' has no output 'angle'; outputs are ['y']
    >>> servo.input(1)
    Traceback (most recent call last):
      ...
    netcosim.plant.ports.UnknownPortError: plant 'servo' has 1 inputs ['u'], index 1 is out of range
    """

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


def _select(names: Sequence[str], key, kind: str, plant: str):
    """Map a name, an index, a slice or a list of those to an index into *names*."""
    if key is None:
        return slice(None), "all"
    if isinstance(key, slice):
        return key, f"[{key.start}:{key.stop}]"
    if isinstance(key, (list, tuple)):
        idx = [(_select(names, k, kind, plant)[0]) for k in key]
        return np.asarray(idx, dtype=int), ",".join(str(k) for k in key)
    if isinstance(key, str):
        try:
            return names.index(key), key
        except ValueError:
            raise UnknownPortError(f"plant {plant!r} has no {kind} {key!r}; {kind}s are {list(names)}") from None
    if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
        if not -len(names) <= key < len(names):
            raise UnknownPortError(f"plant {plant!r} has {len(names)} {kind}s {list(names)}, index {key} is out "
                                   "of range")
        return int(key), names[int(key)]
    raise ConfigurationTypeError(f"{kind} selector must be a name, index, slice or list, got {key!r}")
