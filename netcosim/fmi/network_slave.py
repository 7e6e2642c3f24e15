"""The runtime of an exported network FMU: a pythonfmu ``Fmi2Slave`` running a netcosim network.

:func:`netcosim.fmi.export.export_network_fmu` writes a script whose class derives from
:class:`NetworkSlave` with its ``SPEC`` filled in; pythonfmu packages it as an FMI 2.0
co-simulation FMU.  When an orchestrator loads the FMU, this module runs inside it (the
FMU needs netcosim, and pythonfmu's runtime, in the Python it embeds).

Port mapping (``N`` is a station name of ``SPEC["nodes"]``, ``k`` its index in that list,
from 0):

========================  =========  =======  ==============================================
variable                  causality  type     meaning
========================  =========  =======  ==============================================
``seed``                  parameter  Integer  the simulation's seed (losses, back-offs, ...)
``N.tx_seq``              input      Integer  a change to a value != 0 sends a message at the
                                              communication point, tagged with this number
``N.tx_dst``              input      Integer  the index of the destination station
``N.tx_value``            input      Real     the payload (one number)
``N.tx_bits``             input      Integer  the message's size in bits (0: ``size_bits``)
``N.rx_count``            output     Integer  messages delivered to N so far
``N.rx_seq``              output     Integer  tag of the last message delivered to N
``N.rx_src``              output     Integer  index of its sender
``N.rx_value``            output     Real     its payload
``N.rx_delay``            output     Real     its delay, delivery minus send time (s)
``N.tx_dropped``          output     Integer  messages N's MAC dropped (retry limit, queue)
========================  =========  =======  ==============================================

A message is sent at the start of the ``doStep`` whose inputs carry its new ``tx_seq``,
so at the communication point, and the network runs to the end of the step.  When
several messages reach one station within one step, the outputs show the last one and
``rx_count`` how many arrived: step at least as finely as messages arrive to see each.
A message lost on the medium never appears at its receiver.
"""

from __future__ import annotations

import importlib
from typing import Any

from pythonfmu import Fmi2Causality, Fmi2Initial, Fmi2Slave, Fmi2Variability, Integer, Real

__all__ = ["NetworkSlave", "load_builder", "TX_INPUTS", "RX_OUTPUTS"]

#: the inputs of each station: name suffix -> (type, start)
TX_INPUTS = {"tx_seq": ("Integer", 0), "tx_dst": ("Integer", 0), "tx_value": ("Real", 0.0),
             "tx_bits": ("Integer", 0)}
#: the outputs of each station: name suffix -> (type, start)
RX_OUTPUTS = {"rx_count": ("Integer", 0), "rx_seq": ("Integer", 0), "rx_src": ("Integer", -1),
              "rx_value": ("Real", 0.0), "rx_delay": ("Real", 0.0), "tx_dropped": ("Integer", 0)}


def load_builder(spec: str):
    """The function *spec*, written ``module:function`` (the network builder ``fn(sim) -> network``)."""
    module, _, name = spec.partition(":")
    if not module or not name:
        raise ValueError(f"a network builder is 'package.module:function', got {spec!r}")
    fn = getattr(importlib.import_module(module), name, None)
    if not callable(fn):
        raise ValueError(f"{spec!r}: module {module!r} has no function {name!r}")
    return fn


class NetworkSlave(Fmi2Slave):
    """An FMI 2.0 co-simulation slave running the network ``SPEC["builder"](sim)``.

    ``SPEC``: ``{"builder": "module:function", "nodes": [station names], "size_bits": int,
    "seed": int}`` (filled in by the export's generated subclass)."""

    SPEC: dict = {}
    author = "netcosim"
    description = "a netcosim network as an FMI 2.0 co-simulation FMU (see netcosim.fmi.network_slave)"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        spec = self.SPEC
        self.nodes = list(spec["nodes"])
        self.size_bits = int(spec.get("size_bits", 256))
        self.seed = int(spec.get("seed", 0))
        self.register_variable(Integer("seed", causality=Fmi2Causality.parameter,
                                       variability=Fmi2Variability.fixed))
        self.values: dict[str, Any] = {}
        for n in self.nodes:
            for suffix, (kind, start) in TX_INPUTS.items():
                self._register(f"{n}.{suffix}", kind, start, Fmi2Causality.input)
            for suffix, (kind, start) in RX_OUTPUTS.items():
                self._register(f"{n}.{suffix}", kind, start, Fmi2Causality.output)
        self._last_seq = {n: 0 for n in self.nodes}
        self.sim: Any = None
        self.network: Any = None

    def _register(self, name, kind, start, causality):
        self.values[name] = start
        cls = Real if kind == "Real" else Integer
        variability = (Fmi2Variability.discrete if kind == "Integer" or causality == Fmi2Causality.output
                       else Fmi2Variability.continuous)
        initial = Fmi2Initial.exact if causality == Fmi2Causality.output else None
        self.register_variable(cls(name, causality=causality, variability=variability, start=start, initial=initial,
                                   getter=lambda name=name: self.values[name],
                                   setter=lambda v, name=name: self.values.__setitem__(name, v)))

    def _build(self) -> None:
        from netcosim import Simulation
        self.sim = Simulation(seed=int(self.seed))
        self.network = net = load_builder(self.SPEC["builder"])(self.sim)
        for n in self.nodes:
            if n not in net.interfaces:
                raise ValueError(f"network {net.name!r} has no station {n!r} (stations: {list(net.interfaces)})")
            net.interfaces[n].on_receive(lambda msg, n=n: self._delivered(n, msg))

    def _delivered(self, node: str, msg) -> None:
        seq, value = msg.payload
        v = self.values
        v[f"{node}.rx_count"] += 1
        v[f"{node}.rx_seq"] = int(seq)
        v[f"{node}.rx_src"] = self.nodes.index(msg.src)
        v[f"{node}.rx_value"] = float(value)
        v[f"{node}.rx_delay"] = float(msg.delivered - msg.created)

    def do_step(self, current_time: float, step_size: float) -> bool:
        """Send the messages whose ``tx_seq`` changed at *current_time* (s), then run the network
        to the step's end, ``current_time + step_size`` (s)."""
        if self.sim is None:
            self._build()
        sim, v = self.sim, self.values
        if current_time > sim.now:
            sim.run(current_time)
        for n in self.nodes:
            seq = int(v[f"{n}.tx_seq"])
            if seq != self._last_seq[n] and seq != 0:
                self._last_seq[n] = seq
                dst = self.nodes[int(v[f"{n}.tx_dst"])]
                bits = int(v[f"{n}.tx_bits"]) or self.size_bits
                self.network.interfaces[n].send(dst, (seq, float(v[f"{n}.tx_value"])), bits)
        sim.run(current_time + step_size)
        for n in self.nodes:
            iface = self.network.interfaces[n]
            while iface.receive() is not None:     # the outputs hold what arrived; keep the mailbox empty
                pass
            v[f"{n}.tx_dropped"] = int(iface.stats["dropped"])
        return True
