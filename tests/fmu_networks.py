"""Network builders for the export tests: ``fn(sim) -> network`` (tests/test_fmi_export.py).

A one-file module, so that the exported FMU carries it (netcosim.fmi.export)."""

from netcosim.network import CSMACD, IdealLink


def ethernet(sim):
    """Three stations on a 1 Mbit/s CSMA/CD segment losing 20 % of the frames (Bernoulli):
    collisions, random back-offs and losses, all drawn from the simulation's seed."""
    net = CSMACD(sim, "lan", data_rate=1e6, loss=0.2)
    for n in ("a", "b", "c"):
        net.attach(n)
    return net


def link(sim):
    """Two stations on an ideal 1 Mbit/s link (a fixed delay: the message's transmission time)."""
    net = IdealLink(sim, "link", data_rate=1e6)
    net.attach("a")
    net.attach("b")
    return net
