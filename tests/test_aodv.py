"""TrueTime's AODV example (experiments/aodv.py, netcosim/controllers/aodv.py): the links the
geometry gives, the first route, its break and repair, and the hello-interval comparison."""

from __future__ import annotations

import math

import pytest

from netcosim.controllers.aodv import AODVParams
from netcosim.errors import ConfigurationError
from netcosim.experiments import aodv


def test_links_from_the_geometry_and_truetime_path_loss():
    # P_rx = -8 dBm - 35 log10(d + 1) >= -48 dBm  <=>  d <= 10**(40/35) - 1 = 12.89 m
    links = aodv.link_table(0.0)
    in_range = {(a, b) for a, b, ok in zip(links["a"], links["b"], links["in_range"]) if ok}
    assert in_range == {(1, 2), (1, 3), (2, 4), (3, 5), (4, 5), (4, 6), (5, 7)}
    p = {(a, b): v for a, b, v in zip(links["a"], links["b"], links["rx_dbm"])}
    assert p[(1, 3)] == pytest.approx(-8 - 35 * math.log10(math.sqrt(125) + 1))
    assert p[(1, 3)] == pytest.approx(-46.00, abs=0.01) and p[(5, 7)] == pytest.approx(-44.45, abs=0.01)
    assert p[(2, 3)] == pytest.approx(-50.89, abs=0.01)          # 15.81 m: out of range
    # node 5 loses node 7 at t = 3 + sqrt(12.89**2 - 10**2) / 2 = 7.07 s; node 6 reaches it at 13.43 s
    assert (5, 7) in {(a, b) for a, b, ok in aodv.link_table(7.0)[["a", "b", "in_range"]].itertuples(index=False) if ok}
    late = aodv.link_table(7.1)
    assert not late[(late["a"] == 5) & (late["b"] == 7)]["in_range"].iloc[0]
    for t, expected in ((13.4, False), (13.5, True)):
        lt = aodv.link_table(t)
        assert bool(lt[(lt["a"] == 6) & (lt["b"] == 7)]["in_range"].iloc[0]) is expected


def test_first_route_break_and_repair_via_node_6():
    state, d, row = aodv.run_one(hello_interval=1.0, seed=0)
    assert row["first_route"] == "1-3-5-7" and row["last_route"] == "1-2-4-6-7"
    # messages 0..14 (sent up to 7 s) over 1-3-5-7; 15..20 (7.5-10 s) lost while the broken
    # route still looked valid at node 1 (node 5 misses node 7's hellos for 2 s, RERR at 10.04 s)
    assert (d["route"][:15] == "1-3-5-7").all()
    assert list(d[d["delivered"].isna()]["seq"]) == [15, 16, 17, 18, 19, 20]
    assert row["break_noticed"] == pytest.approx(10.0435, abs=1e-3)
    # from 10.5 s buffered at node 1; the RREQ of 13.5 s (node 6 in range of 7 from 13.43 s) repairs
    assert row["route_repaired"] == pytest.approx(13.507, abs=1e-3)
    assert (d["route"][21:] == "1-2-4-6-7").all()
    assert row["delivered"] == 34 and row["lost"] == 6
    assert (d["delivered"][21:28] > 13.5).all()                  # the buffered ones arrive after the repair


def test_shorter_hello_interval_loses_fewer():
    lost = {h: aodv.run_one(hello_interval=h, seed=0)[2]["lost"] for h in aodv.HELLO_INTERVALS}
    assert lost == {0.25: 1, 0.5: 3, 1.0: 6, 2.0: 10}
    for seed in (1, 4):
        per = [aodv.run_one(hello_interval=h, seed=seed)[2]["lost"] for h in aodv.HELLO_INTERVALS]
        assert per == sorted(per) and per[0] < per[-1], (seed, per)


def test_default_capture_threshold_loses_the_rreq_flood_at_hidden_terminal_overlaps():
    # why CAPTURE_DB = 3 dB: with netcosim's default 10 dB, nodes 2 and 3 re-broadcasting a RREQ
    # together (heard at node 4 at -44.4 and -50.9 dBm, 6.5 dB apart) destroy each other, and with
    # HELLO_INTERVAL 0.5 s no route is found after the break
    sim, _, state = aodv.build(hello_interval=0.5, seed=0, capture_db=10.0)
    sim.run(until=aodv.UNTIL)
    d = aodv.deliveries(state)
    assert set(d["route"]) == {"1-3-5-7", ""} and d["delivered"].isna().sum() == 25


def test_aodv_params_reject_bad_values():
    assert AODVParams(hello_interval=0.5, allowed_hello_loss=3).delete_period == 1.5
    with pytest.raises(ConfigurationError, match="hello_interval"):
        AODVParams(hello_interval=0.0)
    with pytest.raises(ConfigurationError, match="allowed_hello_loss"):
        AODVParams(allowed_hello_loss=0)


def test_main_quick_writes_figures_and_tables(tmp_path):
    summary = aodv.main(str(tmp_path), quick=True)
    for f in ("route.png", "hello_interval.png"):
        assert (tmp_path / f).stat().st_size > 10_000
    for f in ("summary.parquet", "deliveries.parquet", "events.parquet", "links.parquet"):
        assert (tmp_path / f).exists()
    assert list(summary["lost"]) == [1, 3, 6, 10]
