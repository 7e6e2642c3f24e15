"""TrueTime's gateway example (experiments/gateway.py): end-to-end delays against hand
computation, and the one-disturbance-frame-per-hop bound."""

from __future__ import annotations

import numpy as np
import pytest

from netcosim.errors import ConfigurationError
from netcosim.experiments import gateway
from netcosim.plants.first_order import FirstOrder
from netcosim.timebase import TICKS_PER_SECOND


def ticks(seconds):
    return np.rint(np.asarray(seconds) * TICKS_PER_SECOND).astype(np.int64)


def test_undisturbed_delay_is_the_hand_computed_sum_to_the_tick():
    # 250-bit frames: 2 ms; 160-bit frames: 1.28 ms (125 kbit/s, above the 29-bit minimum)
    by_hand = 2 * 0.002 + 2 * 0.00128 + 2 * 0.0025 + 0.005 + 0.005       # + gateway x2, controller, actuator
    assert gateway.NOMINAL_DELAY == pytest.approx(by_hand, abs=1e-15)
    sim, nets = gateway.build(disturbance=False)
    sim.run(until=1.0)
    d = gateway.delays(sim)
    assert len(d) == 25                                   # one actuation per 40 ms period
    assert set(ticks(d["delay"])) == {21_560_000_000}     # 21.56 ms in ps, every sample
    # actuation = release k*40 ms + sensor execution 5 ms + 21.56 ms
    assert (ticks(d["time"]) == np.arange(25) * 40_000_000_000 + 26_560_000_000).all()
    waits = gateway.chain_waits(sim, nets)
    assert (waits["wait"] == 0).all() and len(waits) == 4 * 25


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_disturbed_delays_within_the_worst_case_of_one_frame_per_hop(seed):
    assert gateway.WORST_CASE_DELAY == pytest.approx(0.02156 + 4 * 0.010 + 2 * 0.0025)
    sim, nets = gateway.build(disturbance=True, seed=seed)
    sim.run(until=10.0)
    d = gateway.delays(sim)
    waits = gateway.chain_waits(sim, nets)
    # the premise of the bound held in this run: each loop frame waited for at most one
    # disturbance frame, hence at most 10 ms (its whole transmission)
    assert waits["disturbance_frames"].max() == 1
    assert waits["wait"].max() <= 0.010 + 1e-12
    assert (waits["wait"] > 0).sum() > 20                # the disturbance did get in the way
    assert len(d) == 250
    assert d["delay"].min() == pytest.approx(gateway.NOMINAL_DELAY, abs=1e-12)
    assert d["delay"].max() <= gateway.WORST_CASE_DELAY
    assert d["delay"].max() > gateway.NOMINAL_DELAY + 0.010   # at least one full frame of extra delay


def test_the_disturbance_stream_depends_only_on_the_seed():
    a = gateway.build(seed=3)[0]
    a.run(until=1.0)
    b = gateway.build(seed=3)[0]
    b.run(until=1.0)
    assert gateway.delays(a).equals(gateway.delays(b))


def test_process_output_matches_the_exact_sampled_data_loop():
    # y' = (10 u - y)/10, y(0) = 1; sample k at 40k + 5 ms, u_k = -2 y_k applied at 40k + 26.56 ms
    # (zero-order hold, u = 0 before): the exact solution between input changes, by hand
    def step(y, u, dt):
        return y * np.exp(-dt / 10) + 10 * u * (1 - np.exp(-dt / 10))
    t, y, u, pending = 0.0, 1.0, 0.0, None
    events = sorted([(0.040 * k + 0.005, "sample") for k in range(25)] +
                    [(0.040 * k + 0.02656, "act") for k in range(25)])
    for te, kind in events:
        y, t = step(y, u, te - t), te
        if kind == "sample":
            pending = -2 * y
        else:
            u = pending
    y_end = step(y, u, 0.999 - t)        # the last logged instant (1 ms log interval)
    sim, _ = gateway.build(disturbance=False)
    sim.run(until=1.0)
    sig = sim.trace.signals()
    sim_y = sig[(sig["source"] == "process") & (sig["signal"] == "y.y")]
    at_1s = sim_y[np.isclose(sim_y["time"], 0.999, rtol=0, atol=1e-9)]["value"]
    assert len(at_1s) == 1 and float(at_1s.iloc[0]) == pytest.approx(y_end, rel=1e-6)
    assert y_end == pytest.approx(0.1069, abs=1e-4)       # faster than exp(-2.1) = 0.122 (u held from older y)


def test_first_order_plant_rejects_bad_parameters():
    assert FirstOrder(k=10, tau=10).B[0, 0] == 1.0
    with pytest.raises(ConfigurationError, match="tau"):
        FirstOrder(tau=0.0)
    with pytest.raises(ConfigurationError, match="gain k"):
        FirstOrder(k=float("nan"))


def test_main_quick_writes_figure_and_tables(tmp_path):
    summary = gateway.main(str(tmp_path), quick=True)
    assert (tmp_path / "delay.png").stat().st_size > 10_000
    assert (tmp_path / "summary.parquet").exists() and (tmp_path / "disturbed_hops.parquet").exists()
    undisturbed = summary[~summary["disturbance"]].iloc[0]
    assert undisturbed["max_delay"] == pytest.approx(0.02156, abs=1e-12)
    assert summary[summary["disturbance"]]["mean_delay"].iloc[0] > 0.02156
