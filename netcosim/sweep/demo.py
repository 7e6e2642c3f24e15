"""A small scenario for the sweep's examples: messages over a lossy link.

The docstrings of :mod:`netcosim.sweep` and :mod:`netcosim.view` sweep it; being a
module-level function, it also runs on worker processes and Dask workers by name
(``"netcosim.sweep.demo:lossy_link"``) without a file of the reader's.

Examples
--------
About ``100 (1 - p)`` of the 100 messages arrive:

>>> from netcosim.sweep.demo import lossy_link
>>> lossy_link({"loss": 0.1}, seed=0)
{'received': 92}
"""

from __future__ import annotations

from typing import Any


def lossy_link_run(loss: float, seed: int) -> tuple[Any, list[float]]:
    """Run the scenario: node ``a`` sends a 100-bit message every ms (priority 1, 10 µs
    of CPU per job) to node ``b`` over an :class:`~netcosim.network.IdealLink` at 1 Mbit/s
    whose frames are lost with probability *loss*, for 0.1 s (100 messages).

    Parameters
    ----------
    loss : float
        Frame loss probability of the link, in [0, 1].
    seed : int
        The simulation's seed.

    Returns
    -------
    (Simulation, list of float)
        The simulation after the run, and the arrival times (s) of the messages ``b``
        received.

    Examples
    --------
    >>> from netcosim.sweep.demo import lossy_link_run
    >>> sim, arrivals = lossy_link_run(0.5, seed=0)
    >>> len(arrivals), round(arrivals[0], 6)
    (48, 0.0001)
    """
    from netcosim.network import IdealLink
    from netcosim.sim import Simulation

    sim = Simulation(seed=seed)
    net = IdealLink(sim, "link", data_rate=1e6, loss=loss)
    a, b, arrivals = sim.node("a"), sim.node("b"), []
    net.attach(a)
    net.attach(b).on_receive(lambda msg: arrivals.append(sim.now))

    @a.periodic(period=0.001, priority=1)
    def send(ctx):
        ctx.send("b", None, 100)
        yield ctx.execute(1e-5)

    sim.run(until=0.1)
    return sim, arrivals


def lossy_link(params: dict[str, Any], seed: int) -> dict[str, Any]:
    """The sweep scenario: :func:`lossy_link_run` with ``params["loss"]``; returns the
    number of messages received as ``{"received": n}``.

    Parameters
    ----------
    params : dict
        The run's parameters; ``params["loss"]`` is the frame loss probability.
    seed : int
        The run's seed.

    Examples
    --------
    >>> from netcosim.sweep import run_sweep
    >>> from netcosim.sweep.demo import lossy_link
    >>> run_sweep(lossy_link, {"loss": [0.1, 0.5]}, seeds=2, executor="serial",
    ...           quiet=True).runs["received"].tolist()
    [88, 87, 53, 54]
    """
    _, arrivals = lossy_link_run(params["loss"], seed)
    return {"received": len(arrivals)}
