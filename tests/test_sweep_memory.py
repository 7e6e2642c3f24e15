"""Serial sweeps: a finished simulation is freed by one ``gc.collect()``.

A simulation is a web of reference cycles, so reference counting alone does not free it
(see ``benchmarks/sweep_memory.py``); a sweep runner calls ``gc.collect()`` after a run.
That is enough only if nothing outside the simulation (a module-level cache, a registry,
a closure kept by a library) still refers to it: these tests hold a weak reference to a
finished simulation, drop every strong one, collect once, and expect it dead.
"""

import gc
import weakref

import pytest

from netcosim.experiments.networked_servo import build


@pytest.mark.parametrize("network", ["csma_cd", "can"])
def test_a_finished_networked_servo_is_freed_by_one_collection(network):
    sim, net = build(network=network, share=0.3, seed=1)
    sim.run(0.2)
    frames = net.frames()
    assert len(frames) > 0
    ref = weakref.ref(sim)
    trace = weakref.ref(sim.trace)
    del sim, net
    gc.collect()
    assert ref() is None and trace() is None
    assert len(frames) > 0          # the tables read before stay usable


def test_a_failed_simulation_is_freed_by_one_collection():
    from netcosim import Simulation

    sim = Simulation(seed=0)

    def boom():
        raise RuntimeError("boom")
    sim.call_at(0.01, boom)
    with pytest.raises(RuntimeError) as exc:
        sim.run(0.1)
    ref = weakref.ref(sim)
    del sim, exc                    # the traceback refers to the simulation's frames too
    gc.collect()
    assert ref() is None
