"""experiments/loss_sweep_servo.py: the scenario function on real numbers (frame loss vs
message loss on 802.11b, cost of the loop), and main() end to end on a small sweep."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.stats import binomtest

from netcosim.errors import ConfigurationError
from netcosim.experiments import loss_sweep_servo as exp


def ci99(k: int, n: int):
    return binomtest(k, n).proportion_ci(confidence_level=0.99)


def test_no_loss_both_modes_give_the_loss_free_loop():
    b = exp.scenario({"loss": 0.0, "mode": "broadcast"}, 1)
    u = exp.scenario({"loss": 0.0, "mode": "unicast"}, 1)
    for r in (b, u):
        assert r["frame_loss"] == 0.0 and r["message_loss"] == 0.0 and not r["diverged"]
        # the servo tracks the +-1 rad square wave: J is dominated by the two reference steps
        assert 0.3 < r["J"] < 1.0
    # the ACK exchange adds 0.3 ms of delay per message, which barely changes the cost
    assert u["J"] == pytest.approx(b["J"], rel=0.02)
    assert list(u["trajectory"].columns) == ["time", "error"]
    np.testing.assert_allclose(u["trajectory"]["time"].to_numpy()[:3], [0.0, 0.02, 0.04])


def test_broadcast_message_loss_is_the_frame_loss_unicast_is_p_to_the_attempts():
    p = 0.5
    b = exp.scenario({"loss": p, "mode": "broadcast"}, 3)
    u = exp.scenario({"loss": p, "mode": "unicast"}, 3)
    # broadcast: every frame is a message
    assert (b["messages"], b["messages_lost"]) == (b["attempts"], b["frames_lost"])
    assert b["message_loss"] == b["messages_lost"] / b["messages"]
    ci = ci99(b["messages_lost"], b["messages"])
    assert ci.low <= p <= ci.high
    assert b["diverged"]                                 # half the samples lost: the loop is lost
    # unicast: frames are lost as often, messages p**6 of the time; the loop keeps its cost
    ci = ci99(u["frames_lost"], u["attempts"])
    assert ci.low <= p <= ci.high
    assert u["attempts"] > 1.8 * u["messages"]           # about 1/(1 - p) = 2 attempts per message
    ci = ci99(u["messages_lost"], u["messages"])
    assert ci.low <= p ** exp.RETRY_LIMIT <= ci.high
    assert u["message_loss"] < 0.05
    assert not u["diverged"]
    loss_free = exp.scenario({"loss": 0.0, "mode": "unicast"}, 3)["J"]
    assert u["J"] == pytest.approx(loss_free, rel=0.1)


def test_same_seed_same_result():
    a = exp.scenario({"loss": 0.3, "mode": "unicast"}, 7)
    b = exp.scenario({"loss": 0.3, "mode": "unicast"}, 7)
    assert {k: v for k, v in a.items() if k != "trajectory"} == {k: v for k, v in b.items() if k != "trajectory"}
    assert a["trajectory"].equals(b["trajectory"])


@pytest.mark.parametrize("params, match", [
    ({"loss": 0.1, "mode": "unicast", "rate": 2}, r"unknown key\(s\) \['rate'\]"),
    ({"loss": 0.1}, r"missing \['mode'\]"),
    ({"loss": 1.5, "mode": "unicast"}, r"loss.*1\.5"),
    ({"loss": 0.1, "mode": "multicast"}, "'multicast'"),
])
def test_bad_params_name_the_value(params, match):
    with pytest.raises(ConfigurationError, match=match):
        exp.scenario(params, 0)


def test_the_scenario_declares_its_parameters():
    assert set(exp.scenario.params) == {"loss", "mode"}


def test_main_quick_end_to_end(tmp_path, monkeypatch):
    # 0.5 s runs in this process (serial executor), so the sweep takes seconds
    monkeypatch.setattr(exp, "DURATION", 0.5)
    runs = exp.main(outdir=str(tmp_path), quick=True, executor="serial")
    assert len(runs) == 3 * 2 * 3
    assert set(runs["status"]) == {"ok"}
    assert sorted(set(runs["loss"])) == [0.0, 0.5, 0.9] and set(runs["mode"]) == {"broadcast", "unicast"}
    for name in ("cost.png", "message_loss.png", "summary.parquet", "dataset"):
        assert (tmp_path / name).exists(), name
    summary = pd.read_parquet(tmp_path / "summary.parquet")
    assert summary["n"].tolist() == [3] * 6
    loss_free = summary[summary["loss"] == 0.0]
    assert loss_free["n_diverged"].tolist() == [0, 0] and loss_free["median"].iloc[0] == loss_free["median"].iloc[1]
    # broadcast at p = 0.9: the measured message loss is the frame loss, run by run
    b = runs[(runs["mode"] == "broadcast") & (runs["loss"] == 0.9)]
    assert (b["message_loss"] == b["frame_loss"]).all() and (b["message_loss"] > 0.8).all()
    u = runs[(runs["mode"] == "unicast") & (runs["loss"] == 0.9)]
    assert (u["message_loss"] < 0.75).all()            # 0.9**6 = 0.53
    # the sweep resumes: a second call reruns nothing and returns the same table
    again = exp.main(outdir=str(tmp_path), quick=True, executor="serial")
    cols = [c for c in runs.columns if c != "wall_time"]
    pd.testing.assert_frame_equal(again[cols], runs[cols])
    from netcosim.sweep import load_sweep
    assert load_sweep(tmp_path / "dataset").summary["missing"] == 0
