"""Message loss next to frame loss (issue 23): counters, ``message_loss=``, the masked-loss notice."""

from __future__ import annotations

import math
import warnings

import pytest

from netcosim import Simulation
from netcosim.network import (
    BROADCAST,
    CAN,
    IdealLink,
    MaskedLossWarning,
    SwitchedEthernet,
    WLAN80211b,
    loss_summary,
)

Z = 3.2905  # two-sided 99.9 % normal quantile


def wilson(k: int, n: int, z: float = Z) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion k/n."""
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return c - h, c + h


def wlan_pair(n: int, seed: int = 7, period: float = 5e-3, **kw):
    """802.11b unicast a -> b, 1 m apart, one 100-byte message every *period*."""
    sim = Simulation(seed=seed)
    net = WLAN80211b(sim, "wlan", **kw)
    a = net.attach("a", position=(0.0, 0.0))
    b = net.attach("b", position=(1.0, 0.0))
    for k in range(n):
        sim.call_at(k * period, lambda: a.send("b", None, 800))
    return sim, net, a, b


def quiet_run(sim, until):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MaskedLossWarning)
        sim.run(until)


def test_frame_loss_on_80211b_unicast_shows_the_message_loss_it_caused():
    p, n = 0.5, 20000
    sim, net, a, b = wlan_pair(n, loss=p)
    quiet_run(sim, n * 5e-3 + 0.1)
    s = net.stats
    link, tot = s["links"]["a->b"], s["total"]
    assert list(s["links"]) == ["a->b"]
    assert link == tot
    # the counters agree with each other, with the interfaces and with the frames trace
    assert tot["messages_sent"] == n
    assert tot["messages_in_flight"] == 0
    assert tot["messages_delivered"] + tot["messages_lost"] == n
    assert tot["messages_delivered"] == b.stats["received"] == a.stats["sent"]
    assert tot["messages_lost"] == a.stats["dropped"]
    assert tot["messages_silenced"] == 0
    fr = net.frames()
    assert (fr["event"] == "delivered").sum() == tot["messages_delivered"]
    assert ((fr["event"] == "lost") & (fr["outcome"] == "retry_limit")).sum() == tot["messages_lost"]
    attempts = fr[fr["event"] == "attempt_end"]
    assert len(attempts) == tot["frame_attempts"]
    # every failed attempt here is a random loss at the receiver (one sender, 1 m: no collision, no bit error)
    assert (attempts["outcome"] == "random_loss").sum() == tot["frames_lost"]
    assert tot["frame_loss"] == tot["frames_lost"] / tot["frame_attempts"]
    assert tot["message_loss"] == tot["messages_lost"] / n
    # frame loss ~ p; message loss ~ p**7 (retry_limit 7 attempts), and not p**6 or p**8
    lo, hi = wilson(tot["frames_lost"], tot["frame_attempts"])
    assert lo <= p <= hi
    lo, hi = wilson(tot["messages_lost"], n)
    assert lo <= p ** 7 <= hi, (tot["messages_lost"], n, lo, hi)
    assert not lo <= p ** 6 <= hi and not lo <= p ** 8 <= hi
    # the flat summary for sweeps
    summary = loss_summary(sim)
    assert summary == tot
    assert loss_summary(sim, "wlan") == loss_summary(sim, net) == tot


def test_message_loss_option_gives_the_message_loss_asked_for_and_never_uses_the_medium():
    p, n = 0.3, 5000
    sim, net, a, b = wlan_pair(n, message_loss=p)
    sim.run(n * 5e-3 + 0.1)
    tot = net.stats["total"]
    assert tot["messages_sent"] == n and tot["messages_in_flight"] == 0
    assert tot["messages_lost"] == tot["messages_silenced"]
    assert tot["messages_delivered"] == b.stats["received"]
    lo, hi = wilson(tot["messages_lost"], n)
    assert lo <= p <= hi, (tot["messages_lost"], n, lo, hi)
    # a silenced message has no attempt: one attempt per delivered message, no retry, no frame loss
    assert tot["frame_attempts"] == tot["messages_delivered"]
    assert tot["frames_lost"] == 0
    fr = net.frames()
    silenced = set(fr.loc[(fr["event"] == "lost") & (fr["outcome"] == "message_loss"), "frame"])
    assert len(silenced) == tot["messages_silenced"]
    on_air = set(fr.loc[fr["event"].isin(["queued", "attempt_start", "attempt_end", "ack"]), "frame"])
    assert not silenced & on_air
    assert set(fr.loc[fr["event"] == "created", "frame"]) - silenced == on_air
    # the sender's network schedule: one sending interval per delivered message, none for a silenced one
    sch = net.schedule()
    sending = sch[(sch["node"] == "a") & (sch["state"] == "sending")]
    assert len(sending) == tot["messages_delivered"]
    # silenced messages count as dropped at the sender (on_done sees ok=False)
    assert a.stats["dropped"] == tot["messages_silenced"]


def test_message_loss_on_a_wired_network_and_per_receiver_for_broadcast():
    p, n = 0.2, 4000
    sim = Simulation(seed=3)
    net = CAN(sim, "can", data_rate=500e3, message_loss=p)
    ifs = [net.attach(x, priority=i) for i, x in enumerate("abc")]
    for k in range(n):
        sim.call_at(k * 1e-3, lambda: ifs[0].send(BROADCAST, None, 64))
    sim.run(n * 1e-3 + 0.01)
    s = net.stats
    assert set(s["links"]) == {"a->b", "a->c"}
    for name, rx in (("a->b", ifs[1]), ("a->c", ifs[2])):
        link = s["links"][name]
        assert link["messages_sent"] == n and link["messages_in_flight"] == 0
        assert link["messages_delivered"] == rx.stats["received"]
        lo, hi = wilson(link["messages_lost"], n)
        assert lo <= p <= hi
    # a broadcast silenced on both links never goes on the bus; silenced on one, it goes to the other
    fr = net.frames()
    starts = (fr["event"] == "attempt_start").sum()
    both = ((fr["event"] == "lost") & (fr["outcome"] == "message_loss")).groupby(fr["frame"]).sum()
    assert starts == n - (both == 2).sum()
    assert s["total"]["messages_sent"] == 2 * n


def test_same_seed_same_counters_other_seed_other_counters():
    def run(seed):
        sim, net, a, b = wlan_pair(2000, seed=seed, loss=0.4, message_loss=0.1)
        quiet_run(sim, 2000 * 5e-3 + 0.1)
        return net.stats, net.frames()

    s1, f1 = run(11)
    s2, f2 = run(11)
    s3, _ = run(12)
    assert s1 == s2
    assert f1.equals(f2)
    assert s1 != s3


def test_frame_loss_draws_unchanged_by_message_loss_zero_and_counters_free_of_side_effects():
    # message_loss=0 (or None) draws nothing: the frames trace is the one without the option
    sim1, net1, _, _ = wlan_pair(500, loss=0.3)
    sim2, net2, _, _ = wlan_pair(500, loss=0.3, message_loss=0.0)
    quiet_run(sim1, 3.0)
    quiet_run(sim2, 3.0)
    assert net1.frames().equals(net2.frames())
    assert net1.stats == net2.stats


def test_the_masked_loss_notice_appears_once_per_network():
    with pytest.warns(MaskedLossWarning) as rec:
        sim, net, a, b = wlan_pair(50, loss=0.5)
        sim.run(1.0)
    notes = [w for w in rec if issubclass(w.category, MaskedLossWarning)]
    assert len(notes) == 1
    text = str(notes[0].message)
    assert "'wlan'" in text and "0.5**7" in text and "0.00781" in text and "message_loss=0.5" in text
    # a second network gets its own notice
    with pytest.warns(MaskedLossWarning) as rec:
        sim2, net2, a2, _ = wlan_pair(5, loss=0.5)
        net3 = WLAN80211b(sim2, "wlan2", loss=0.5)
        x = net3.attach("x", position=(0.0, 0.0))
        net3.attach("y", position=(1.0, 0.0))
        x.send("y", None, 800)
        x.send("y", None, 800)
        sim2.run(0.1)
    assert sorted(str(w.message).split("'")[1] for w in rec if issubclass(w.category, MaskedLossWarning)) == \
        ["wlan", "wlan2"]


@pytest.mark.parametrize("kw", [
    {"loss": 0.04},                       # small frame loss: not noted
    {"loss": 0.5, "retry_limit": 1},      # no retry: message loss = frame loss
    {"message_loss": 0.5},                # already a message loss
    {"loss": 0.9, "retry_limit": 2},      # 0.81 >= 0.09: not masked
])
def test_no_notice_when_the_frame_loss_is_not_masked(kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error", MaskedLossWarning)
        sim, net, a, b = wlan_pair(20, **kw)
        sim.run(0.5)


def test_no_notice_for_broadcast_only_or_wired():
    with warnings.catch_warnings():
        warnings.simplefilter("error", MaskedLossWarning)
        sim = Simulation(seed=1)
        net = WLAN80211b(sim, "wlan", loss=0.5)
        a = net.attach("a", position=(0.0, 0.0))
        net.attach("b", position=(1.0, 0.0))
        a.send(BROADCAST, None, 800)
        wired = IdealLink(sim, "link", data_rate=1e6, loss=0.5)
        c = wired.attach("c")
        wired.attach("d")
        c.send("d", None, 800)
        sim.run(0.1)


def test_delivery_delays_and_switch_keep_the_fate_open_until_it_is_known():
    # post_delay: a message is in flight until handed over, then delivered (not lost)
    sim = Simulation(seed=1)
    net = IdealLink(sim, "link", data_rate=1e6, post_delay=1e-3)
    a = net.attach("a")
    net.attach("b")
    a.send("b", None, 1000)
    sim.run(1.5e-3)          # transmitted (1 ms) and the sender is done, hand-over at 2 ms
    t = net.stats["total"]
    assert (t["messages_sent"], t["messages_delivered"], t["messages_lost"], t["messages_in_flight"]) == (1, 0, 0, 1)
    sim.run(3e-3)
    t = net.stats["total"]
    assert (t["messages_delivered"], t["messages_lost"], t["messages_in_flight"]) == (1, 0, 0)
    assert (t["frame_attempts"], t["frames_lost"]) == (1, 0)
    # switched Ethernet: the sender is done when the switch has the frame, delivery comes later
    sim = Simulation(seed=1)
    sw = SwitchedEthernet(sim, "sw", data_rate=1e6, switch_delay=1e-3)
    x = sw.attach("x")
    sw.attach("y")
    sw.attach("z")
    x.send(BROADCAST, None, 1000)
    sim.run(1.5e-3)
    t = sw.stats["total"]
    assert (t["messages_sent"], t["messages_delivered"], t["messages_lost"], t["messages_in_flight"]) == (2, 0, 0, 2)
    sim.run(5e-3)
    t = sw.stats["total"]
    assert (t["messages_delivered"], t["messages_lost"], t["frame_attempts"], t["frames_lost"]) == (2, 0, 2, 0)


def test_a_full_mailbox_is_a_message_loss_and_a_frame_received():
    sim = Simulation(seed=1)
    net = IdealLink(sim, "link", data_rate=1e6, mailbox_capacity=1)
    a = net.attach("a")
    net.attach("b")
    for _ in range(3):
        a.send("b", None, 100)
    sim.run(0.01)
    link = net.stats["links"]["a->b"]
    assert (link["messages_sent"], link["messages_delivered"], link["messages_lost"]) == (3, 1, 2)
    assert (link["frame_attempts"], link["frames_lost"]) == (3, 0)
    df = net.link_stats()
    assert list(df[["src", "dst"]].iloc[0]) == ["a", "b"] and int(df["messages_lost"].iloc[0]) == 2


def test_message_loss_per_link():
    n = 3000
    sim = Simulation(seed=5)
    net = IdealLink(sim, "link", data_rate=1e6, message_loss={("a", "b"): 0.25, ("a", "c"): 0.0})
    a = net.attach("a")
    net.attach("b")
    net.attach("c")
    for k in range(n):
        sim.call_at(k * 1e-3, lambda: a.send(BROADCAST, None, 100))
    sim.run(n * 1e-3 + 0.01)
    links = net.stats["links"]
    lo, hi = wilson(links["a->b"]["messages_lost"], n)
    assert lo <= 0.25 <= hi
    assert links["a->c"]["messages_lost"] == 0 and links["a->c"]["messages_delivered"] == n
    with pytest.raises(TypeError, match="node-name pairs"):
        IdealLink(sim, "bad", data_rate=1e6, message_loss={"a": 0.1})
    with pytest.raises(ValueError, match="probability"):
        IdealLink(sim, "bad2", data_rate=1e6, message_loss={("a", "b"): 1.5})


# -- models other than Bernoulli: their long-run statistics, and the notice from them --------

def test_gilbert_elliott_consecutive_loss_matches_its_draws():
    import numpy as np

    from netcosim.network import GilbertElliott
    ge = GilbertElliott(p_gb=0.2, p_bg=0.4, loss_good=0.1, loss_bad=0.9)
    assert ge.frame_loss() == pytest.approx(1 / 3 * 0.9 + 2 / 3 * 0.1)
    assert ge.consecutive_loss(1) == pytest.approx(ge.frame_loss())
    # n = 2 by hand: pi_i L_i P_ij L_j summed
    pi, L = np.array([2 / 3, 1 / 3]), np.array([0.1, 0.9])
    P = np.array([[0.8, 0.2], [0.4, 0.6]])
    assert ge.consecutive_loss(2) == pytest.approx(float((pi * L) @ P @ L))
    # the draws: 20 000 links from the stationary state, their first 4 frames
    rng = np.random.default_rng(3)
    n_links, n = 20_000, 4
    hits = 0
    for _ in range(n_links):
        lk = ge.link(rng)
        hits += all([lk.lost() for _ in range(n)])
    lo, hi = wilson(hits, n_links)
    assert lo <= ge.consecutive_loss(n) <= hi
    # bursts: far more than independent losses of the same rate
    assert ge.consecutive_loss(n) > 3 * ge.frame_loss() ** n


def test_trace_loss_statistics_count_windows_of_the_sequence():
    from netcosim.network import TraceLoss
    seq = [1, 1, 0, 1, 1, 1, 0, 0]
    cyc, once = TraceLoss(seq, repeat=True), TraceLoss(seq, repeat=False)
    assert cyc.frame_loss() == once.frame_loss() == 5 / 8
    # windows of 2 starting at 0..7, cyclically: 11, 10, 01, 11, 11, 10, 00, 01 -> 3 of 8
    assert cyc.consecutive_loss(2) == 3 / 8
    # without repeat only the 7 windows inside the sequence: 3 of 7
    assert once.consecutive_loss(2) == 3 / 7
    assert once.consecutive_loss(9) == 0.0 and TraceLoss([1], repeat=True).consecutive_loss(5) == 1.0


def test_the_notice_follows_the_model_statistics_for_bursty_loss():
    from netcosim.network import GilbertElliott
    # short bursts (mean 2 frames), loss 0.5: 7 attempts leave 0.5 * 0.5**6 = 0.0078 -> noted
    with pytest.warns(MaskedLossWarning, match=r"long-run 0.5 per frame.*message loss is only 0.0078"):
        sim, net, a, b = wlan_pair(5, loss=GilbertElliott(p_gb=0.5, p_bg=0.5, loss_good=0.0, loss_bad=1.0))
        sim.run(0.1)
    # long bursts (mean 20 frames): retries do not hide them (0.5 * 0.95**6 = 0.37) -> not noted
    with warnings.catch_warnings():
        warnings.simplefilter("error", MaskedLossWarning)
        sim, net, a, b = wlan_pair(5, loss=GilbertElliott(p_gb=0.05, p_bg=0.05))
        sim.run(0.1)
