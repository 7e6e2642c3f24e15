"""Scenarios for the sweep tests: cheap, deterministic, importable by worker processes.

``SWEEP_TEST_LOG`` (environment): a file each run of :func:`logged` appends one line
to, so a test can count the runs that executed.
"""

import os
import time

import numpy as np
import pandas as pd


def cheap(params, seed):
    """A few random draws from *seed*: a known function of the parameters and the seed."""
    rng = np.random.default_rng(seed)
    x = params["a"] * 10 + params["b"] + float(rng.normal())
    return {"x": x, "draw": int(rng.integers(0, 1000)), "label": f"{params['a']}-{params['b']}",
            "trajectory": pd.DataFrame({"k": np.arange(3), "v": rng.normal(size=3)})}


cheap.params = {"a", "b"}


def logged(params, seed):
    """:func:`cheap`, plus a line in ``$SWEEP_TEST_LOG`` and a short sleep (s)."""
    with open(os.environ["SWEEP_TEST_LOG"], "a") as f:
        f.write(f"{params['a']} {params['b']} {seed}\n")
    time.sleep(float(os.environ.get("SWEEP_TEST_SLEEP", "0")))
    return cheap(params, seed)


def flaky(params, seed):
    """``mode``: "ok" returns, "raise" raises, "hang" sleeps for an hour, "list" returns a list,
    "die" ends its process at once (exit status 3)."""
    mode = params["mode"]
    if mode == "die":
        os._exit(3)
    if mode == "raise":
        raise FloatingPointError(f"diverged at case {params['i']}")
    if mode == "hang":
        time.sleep(3600)
    if mode == "list":
        return [1, 2]
    return {"value": params["i"] * 2}


#: Weak references to the big object of every :func:`cyclic` run.
REFS: list = []


class _Big:
    def __init__(self):
        self.data = np.zeros(100_000)
        self.me = self                       # a reference cycle, as a finished simulation is


def cyclic(params, seed):
    """Leaves a 0.8 MB reference cycle behind (freed only by the cyclic collector)."""
    import weakref

    big = _Big()
    REFS.append(weakref.ref(big))
    return {"n": len(big.data)}


def servo_traced(params, seed):
    """TrueTime's networked servo (:mod:`netcosim.experiments.networked_servo`, CSMA/CD) for
    ``params["until"]`` s with interferer share ``params["share"]``: its cost J, and (opt-in)
    the run's trace tables (unless ``keep_trace`` is false), for the sweep view to link to."""
    from netcosim.experiments.networked_servo import build, control_cost
    from netcosim.view import trace_tables
    sim, _ = build("csma_cd", params["share"], seed=seed)
    until = params.get("until", 0.3)
    sim.run(until=until)
    out = {"cost": control_cost(sim, until)}
    if params.get("keep_trace", True):
        out.update(trace_tables(sim))
    return out


servo_traced.params = {"share", "until", "keep_trace"}
