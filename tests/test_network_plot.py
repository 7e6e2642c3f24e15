"""The network schedule plot: levels (idle lowest), legend, and one marker per lost frame / retransmission."""

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from conftest import lossy_link  # noqa: E402

from netcosim import Simulation  # noqa: E402
from netcosim.network import NETWORK_STATES, WLAN80211b  # noqa: E402
from netcosim.network.plot import LOST_LABEL, RETRANSMISSION_LABEL, plot_network_schedule  # noqa: E402


def test_levels_put_idle_lowest_and_sending_highest():
    assert sorted(NETWORK_STATES, key=NETWORK_STATES.__getitem__) == ["idle", "receiving", "waiting", "sending"]
    assert NETWORK_STATES["idle"] == 0.0 and NETWORK_STATES["sending"] < 1.0



def test_staircase_levels_of_a_known_schedule():
    # a sends 300 bits at 1 Mbit/s every ms: sending for 300 us, idle otherwise; b receives
    sim = lossy_link()
    ax = plot_network_schedule(sim.trace.frame("network_schedule"), t_range=(0.0, 0.0095))
    b_line, a_line = ax.get_lines()[:2]          # drawn bottom row first: b (row 0), a (row 1)
    x, y = a_line.get_data()
    at = lambda t: y[np.searchsorted(x, t, side="right") - 1]  # noqa: E731
    assert at(0.0001) == 1 + NETWORK_STATES["sending"]
    assert at(0.0005) == 1 + NETWORK_STATES["idle"] == 1.0
    xb, yb = b_line.get_data()
    assert set(np.round(yb, 9)) == {0.0, NETWORK_STATES["receiving"]}
    assert [t.get_text() for t in ax.get_yticklabels()] == ["b", "a"]


def test_legend_names_every_state_and_marker():
    sim = lossy_link()
    ax = plot_network_schedule(sim.trace.frame("network_schedule"), frames=sim.trace.frame("frames"))
    texts = [t.get_text() for t in ax.get_legend().get_texts()]
    assert texts == ["sending", "waiting", "receiving", "idle (baseline)", LOST_LABEL, RETRANSMISSION_LABEL]
    ax = plot_network_schedule(sim.trace.frame("network_schedule"))
    assert [t.get_text() for t in ax.get_legend().get_texts()] == ["sending", "waiting", "receiving",
                                                                 "idle (baseline)"]


def _marker(ax, label):
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == label]
    return line.get_data()


def test_one_marker_per_lost_frame_in_the_window():
    sim = lossy_link()
    frames = sim.trace.frame("frames")
    lost = frames[frames["event"] == "lost"]
    assert 2 <= len(lost) <= 8                       # 10 frames at loss 0.5 (seed 3)
    ax = plot_network_schedule(sim.trace.frame("network_schedule"), frames=frames)
    x, y = _marker(ax, LOST_LABEL)
    assert len(x) == len(lost)
    np.testing.assert_array_equal(x, lost["time"].to_numpy())
    assert set(y) == {0 + NETWORK_STATES["sending"]}  # lost at the receiver b (bottom row)
    window = (0.0, 0.0045)
    ax = plot_network_schedule(sim.trace.frame("network_schedule"), frames=frames, t_range=window)
    assert len(_marker(ax, LOST_LABEL)[0]) == int(((lost["time"] >= 0) & (lost["time"] <= 0.0045)).sum())


def test_retransmissions_are_marked_on_the_sender_row():
    # two saturated 802.11b senders collide now and then: every attempt after the first is marked
    sim = Simulation(seed=1)
    net = WLAN80211b(sim, "w", data_rate=11e6, loss=0.3)
    ap = net.attach("ap", mailbox=False)
    a = net.attach("a", position=(5.0, 0.0))
    for k in range(40):
        sim.call_at(k * 2e-3, lambda: a.send(ap, None, 8000))
    sim.run(0.1)
    frames = sim.trace.frame("frames")
    retx = frames[(frames["event"] == "attempt_start") & (frames["attempt"] > 1)]
    lost = frames[frames["event"] == "lost"]
    assert len(retx) >= 5
    ax = plot_network_schedule(sim.trace.frame("network_schedule"), frames=frames)
    x, y = _marker(ax, RETRANSMISSION_LABEL)
    assert len(x) == len(retx)
    assert set(y) == {0 + NETWORK_STATES["sending"]}   # a is the bottom row
    assert len(_marker(ax, LOST_LABEL)[0]) == len(lost)


def test_several_networks_need_a_name():
    sim = lossy_link()
    df = sim.trace.frame("network_schedule")
    df2 = df.copy()
    df2["network"] = "other"
    import pandas as pd
    with pytest.raises(ValueError, match="several networks"):
        plot_network_schedule(pd.concat([df, df2]))
