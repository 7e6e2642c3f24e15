"""The engine (netcosim.clock): the one module that knows SimPy's internals.

Everything else uses its public face; these tests pin what it relies on, so that an
incompatible SimPy fails here, loudly, and not as wrong schedules elsewhere."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import simpy

from netcosim import Simulation
from netcosim.clock import NORMAL, URGENT, Engine, Rearmable, Timer, check_simpy

ROOT = Path(__file__).resolve().parents[1]
#: SimPy's private names: only netcosim/clock.py may touch them
PRIVATE = re.compile(r"\.(_now|_queue|_eid|_ok|_value|_defused|_active_proc)\b")


def test_the_installed_simpy_has_the_shape_the_engine_needs():
    check_simpy()           # raises ImportError naming the version otherwise
    assert simpy.__version__.split(".")[0] == "4"
    pins = [ln for ln in (ROOT / "pyproject.toml").read_text().splitlines() if '"simpy>=' in ln]
    assert pins == ['    "simpy>=4.1,<5",'], pins


def test_an_incompatible_simpy_fails_loudly(monkeypatch):
    # a SimPy whose queue entries gained a field: the check refuses it by name
    def schedule(self, event, priority=NORMAL, delay=0):
        self._queue.append((self._now + delay, priority, next(self._eid), event, "new field"))
    monkeypatch.setattr(simpy.Environment, "schedule", schedule)
    with pytest.raises(ImportError, match=r"installed SimPy 4\.\d+\.\d+ differs: install simpy>=4.1,<5"):
        check_simpy()


def test_no_module_but_the_engine_touches_simpy_private_names():
    offenders = []
    for folder in ("netcosim", "controllers", "plants", "experiments", "benchmarks", "tests"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            if path == ROOT / "netcosim" / "clock.py" or path == Path(__file__).resolve():
                continue
            for n, line in enumerate(path.read_text().splitlines(), 1):
                if PRIVATE.search(line.split("#")[0]):
                    offenders.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert offenders == []


def test_engine_now_follows_simpy_time_through_every_loop():
    env = Engine()
    seen = []
    Timer.call(env, 5, lambda: seen.append(("timer", env.now, env._now)))
    def proc():
        yield env.timeout(7)
        seen.append(("process", env.now, env._now))
    env.process(proc())                         # a SimPy process and timeout work as usual
    env.run_until(10)
    assert seen == [("timer", 5, 5), ("process", 7, 7)] and env.now == env._now == 10
    Timer.call(env, 2, lambda: seen.append(("step", env.now)))
    env.step()                                  # SimPy's step, through Engine.step
    assert seen[-1] == ("step", 12) and env.now == 12
    env.run(until=20)                           # SimPy's own run, through Engine.step
    assert env.now == env._now == 20
    sim = Simulation()
    sim.run(0.25)
    assert sim.env.now == sim.now_ticks == 250_000_000_000


def test_at_rearm_arm_and_mark_keep_simpy_order():
    env = Engine()
    order = []
    t = Timer(env, 3, lambda tm: order.append(("t", env.now)))
    r = Rearmable(env)
    r.arm(3, URGENT, [lambda ev: order.append(("urgent", env.now))])
    m1 = env.mark()
    ev = simpy.events.Event(env)
    ev._ok, ev._value = True, None
    ev.callbacks.append(lambda e: order.append(("at", env.now)))
    env.at(3, NORMAL, ev)
    assert env.mark() == m1 + 2 and env.queued == 3
    env.run_until(4)
    # urgent first, then the two normal ones in the order they were scheduled
    assert order == [("urgent", 3), ("t", 3), ("at", 3)]
    t.rearm(6, [lambda tm: order.append(("again", env.now))])
    r.arm(6, NORMAL, [lambda ev: order.append(("rearmed", env.now))])
    env.run_until(7)
    assert order[3:] == [("again", 6), ("rearmed", 6)]
