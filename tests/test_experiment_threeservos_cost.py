"""The three servos scored by exact expected cost (experiments/threeservos_cost.py)."""

from __future__ import annotations

import numpy as np
import pytest

from netcosim import ExactZOH
from netcosim.controllers.pid import PID
from netcosim.experiments import threeservos as ts
from netcosim.experiments import threeservos_cost as tsc
from netcosim.plants.dc_servo import DCServo


def test_the_pid_model_and_the_coupling_give_the_simulated_cost_without_noise():
    """Zero noise, the servos start at 1 rad: the expected cost of each loop along the
    overloaded EDF schedule equals ∫ y² dt of the ordinary simulation running the real
    PID object on the real plant (the integral by the trapezoid rule on a 10 µs log)."""
    until = 0.3
    n = tsc.loop_model(ts.PERIODS[0]).dynamics().size        # the plant's angle comes first
    sim, costs = tsc.build("edf", noise=0.0, m0=np.r_[1.0, np.zeros(n - 1)])
    servos = []
    for i, h in enumerate(ts.PERIODS, start=1):
        servo = sim.plant(DCServo(), x0=[1.0, 0.0], name=f"servo{i}", integrator=ExactZOH(), log_interval=1e-5)
        pid = PID(h=h)

        def body(ctx, pid=pid, servo=servo):
            u = pid.compute(0.0, ctx.read(servo.output(0)))
            yield ctx.execute(ts.EXECUTION)
            ctx.write(servo.input(0), u)
        servos.append((servo, pid, body))
    # the real loops run on a second node with the same task set, hence the same schedule
    shadow = sim.node("shadow", scheduler="edf")
    for i, ((servo, pid, body), h) in enumerate(zip(servos, ts.PERIODS), start=1):
        shadow.periodic(body, period=h, priority=i, name=f"pid{i}")
    sim.run(until)
    sig = sim.trace.signals()
    for i, ec in enumerate(costs, start=1):
        s = sig[(sig["source"] == f"servo{i}") & (sig["signal"] == "y.y")]
        simulated = np.trapezoid(s["value"].to_numpy() ** 2, s["time"].to_numpy())
        assert ec.cost_until(until) == pytest.approx(simulated, rel=1e-6), i


def test_modes_rank_as_the_schedules_say():
    table = tsc.expected_costs(0.3).pivot(index="mode", columns="loop", values="cost_per_s")
    # deadline monotonic starves loop 1: its expected cost explodes (750x EDF's in 0.3 s)
    assert table.loc["deadline_monotonic", 1] > 100 * table.loc["edf", 1]
    # EDF and the servers keep every loop's cost moderate and finite
    for mode in ("edf", "edf_cbs", "edf_tbs"):
        assert np.isfinite(table.loc[mode]).all() and (table.loc[mode] < 3 * table.loc["edf"]).all(), mode


def test_main_writes_its_table_and_figure(tmp_path):
    table = tsc.main(str(tmp_path), quick=True)
    assert len(table) == 3 * len(ts.MODES)
    assert (tmp_path / "costs.parquet").exists() and (tmp_path / "costs.png").stat().st_size > 5000
