"""Loss models: Bernoulli rates, Gilbert-Elliott bursts, trace replay, composition with the physics."""

import math

import numpy as np
import pytest
from scipy.stats import binomtest, norm

from netcosim import Simulation
from netcosim.network import BROADCAST, Bernoulli, GilbertElliott, IdealLink, TraceLoss, WLAN80211b


def ideal_run(loss, n_frames, seed=1, extra_node=False):
    """a sends n_frames to b over a 1 Gbit/s ideal link; returns the 0/1 loss sequence (by frame)."""
    sim = Simulation(seed=seed)
    net = IdealLink(sim, "link", data_rate=1e9, loss=loss)
    a = net.attach("a", mailbox=False)
    net.attach("b", mailbox=False)
    if extra_node:
        c = net.attach("c", mailbox=False)
        for _ in range(n_frames // 2):
            c.send("b", None, 100)
    for _ in range(n_frames):
        a.send("b", None, 100)
    sim.run(1.0)
    df = net.frames()
    df = df[(df["src"] == "a") & df["event"].isin(["delivered", "lost"])].sort_values("frame")
    assert len(df) == n_frames
    return (df["event"] == "lost").to_numpy().astype(int)


@pytest.mark.parametrize("p", [0.05, 0.3])
def test_bernoulli_loss_rate_is_within_the_99_percent_binomial_interval(p):
    seq = ideal_run(Bernoulli(p), 12000)
    k, n = int(seq.sum()), len(seq)
    ci = binomtest(k, n).proportion_ci(confidence_level=0.99)
    assert ci.low <= p <= ci.high, (k / n, p)
    # and the losses are not bunched: lag-1 autocorrelation ~ 0
    r1 = np.corrcoef(seq[:-1], seq[1:])[0, 1]
    assert abs(r1) < 3.0 / math.sqrt(n)


def _runs(seq, value):
    runs, cur = [], 0
    for v in seq:
        if v == value:
            cur += 1
        elif cur:
            runs.append(cur)
            cur = 0
    if cur:
        runs.append(cur)
    return np.array(runs)


def test_gilbert_elliott_bursts_have_mean_length_one_over_p_bad_to_good():
    ge = GilbertElliott(p_gb=0.02, p_bg=0.25)             # classical Gilbert: lose all in bad, none in good
    seq = ideal_run(ge, 40000, seed=3)
    bursts = _runs(seq, 1)
    # burst lengths are geometric with mean 1/p_bg = 4 and sd sqrt(1 - p_bg)/p_bg
    mean, sd = 1 / 0.25, math.sqrt(1 - 0.25) / 0.25
    half = norm.ppf(0.995) * sd / math.sqrt(len(bursts))
    assert len(bursts) > 500
    assert abs(bursts.mean() - mean) < half, (bursts.mean(), mean, half)
    assert ge.mean_burst == 4.0
    # long-run loss rate = p_gb / (p_gb + p_bg)
    pi_bad = 0.02 / 0.27
    assert ge.loss_rate == pytest.approx(pi_bad)
    assert abs(seq.mean() - pi_bad) < 0.02
    # gaps between bursts: geometric with mean 1/p_gb
    gaps = _runs(seq, 0)
    assert gaps.mean() == pytest.approx(1 / 0.02, rel=0.15)


def test_gilbert_elliott_with_partial_losses_per_state():
    ge = GilbertElliott(p_gb=0.1, p_bg=0.1, loss_good=0.01, loss_bad=0.5, start="good")
    seq = ideal_run(ge, 20000, seed=4)
    expected = 0.5 * 0.01 + 0.5 * 0.5
    assert ge.loss_rate == pytest.approx(expected)
    assert abs(seq.mean() - expected) < 0.03


def test_trace_loss_replays_a_recorded_channel_on_every_link():
    pattern = [0, 1, 1, 0, 0, 0, 1]
    seq = ideal_run(TraceLoss(pattern), 21)
    assert seq.tolist() == pattern * 3
    sim = Simulation()
    net = IdealLink(sim, "l", loss=TraceLoss([1, 0], repeat=False))
    a = net.attach("a")
    net.attach("b")
    for _ in range(3):
        a.send("b", None, 8)
    with pytest.raises(RuntimeError, match="exhausted"):
        sim.run(1.0)


def test_each_link_has_its_own_stream_so_other_traffic_does_not_change_the_draws():
    assert np.array_equal(ideal_run(Bernoulli(0.3), 2000), ideal_run(Bernoulli(0.3), 2000, extra_node=True))


def test_loss_on_wlan_unicast_silences_the_link_and_causes_retries():
    """Random loss at the receiver before the ACK: attempts are geometric, drops are p^7."""
    p, n = 0.5, 3000
    sim = Simulation(seed=5)
    net = WLAN80211b(sim, "w", data_rate=11e6, loss=Bernoulli(p))
    a = net.attach("a", position=(0.0, 0.0))
    net.attach("b", position=(10.0, 0.0), mailbox=False)
    for k in range(n):
        sim.call_at(k * 20e-3, lambda: a.send("b", None, 800))
    sim.run(n * 20e-3 + 0.1)
    df = net.frames()
    ends = df[df["event"] == "attempt_end"]
    assert set(ends["outcome"]) == {"ok", "random_loss"}
    first_ok = int(((ends["outcome"] == "ok") & (ends["attempt"] == 1)).sum())
    ci = binomtest(first_ok, n).proportion_ci(confidence_level=0.99)
    assert ci.low <= 1 - p <= ci.high
    dropped = int((df["event"] == "lost").sum())
    ci = binomtest(dropped, n).proportion_ci(confidence_level=0.99)
    assert ci.low <= p ** 7 <= ci.high
    assert int((df["event"] == "delivered").sum()) == n - dropped


def test_loss_on_wlan_broadcast_is_drawn_per_receiver():
    p, n = 0.2, 4000
    sim = Simulation(seed=6)
    net = WLAN80211b(sim, "w", data_rate=11e6, loss=p)
    a = net.attach("a", position=(0.0, 0.0))
    for name in ("b", "c"):
        net.attach(name, position=(10.0, 5.0), mailbox=False)
    for k in range(n):
        sim.call_at(k * 2e-3, lambda: a.send(BROADCAST, None, 800))
    sim.run(n * 2e-3 + 0.1)
    df = net.frames()
    for rx in ("b", "c"):
        lost = df[(df["event"] == "lost") & (df["node"] == rx)]
        assert set(lost["outcome"]) == {"random_loss"}
        ci = binomtest(len(lost), n).proportion_ci(confidence_level=0.99)
        assert ci.low <= p <= ci.high
    lb = set(df[(df["event"] == "lost") & (df["node"] == "b")]["frame"])
    lc = set(df[(df["event"] == "lost") & (df["node"] == "c")]["frame"])
    assert lb != lc                                             # independent links


@pytest.mark.parametrize("bad,match", [
    (lambda: Bernoulli(1.5), "1.5"),
    (lambda: Bernoulli(-0.1), "-0.1"),
    (lambda: GilbertElliott(p_gb=2.0, p_bg=0.1), "p_gb.*2.0"),
    (lambda: GilbertElliott(p_gb=0.1, p_bg=0.1, loss_bad=float("nan")), "loss_bad"),
    (lambda: TraceLoss([0, 1, 2]), "0/1"),
    (lambda: IdealLink(Simulation(), "l", loss=-0.5), "loss probability.*-0.5"),
])
def test_bad_loss_parameters_raise_naming_the_value(bad, match):
    with pytest.raises(ValueError, match=match):
        bad()
    with pytest.raises(TypeError, match="loss"):
        IdealLink(Simulation(), "l", loss="often")


def _message_loss(mode: str, p: float, n: int, retry_limit: int = 7, seed: int = 8):
    """a sends n messages to b (unicast) or to every other station (broadcast, one receiver)
    every 20 ms; returns (messages lost, attempts made, attempts lost by the loss draw)."""
    sim = Simulation(seed=seed)
    net = WLAN80211b(sim, "w", data_rate=11e6, loss=p, retry_limit=retry_limit)
    a = net.attach("a", position=(0.0, 0.0))
    b = net.attach("b", position=(10.0, 0.0), mailbox=False)
    dst = BROADCAST if mode == "broadcast" else "b"
    for k in range(n):
        sim.call_at(k * 20e-3, lambda: a.send(dst, None, 800))
    sim.run(n * 20e-3 + 0.5)
    df = net.frames()
    ends = df[df["event"] == "attempt_end"]
    random = int((df["outcome"] == "random_loss").sum()) if mode == "broadcast" else \
        int((ends["outcome"] == "random_loss").sum())
    assert a.stats["sent"] + a.stats["dropped"] == n
    return n - b.stats["received"], len(ends), random


def test_frame_loss_is_per_attempt_message_loss_depends_on_retries():
    """``loss`` is a per-frame probability (per attempt, per receiver).  Broadcast: one
    attempt, message loss = p.  Unicast: ``retry_limit`` counts *attempts* (the frame is
    dropped when ``attempts >= retry_limit``), so with only the loss draw failing attempts
    the message loss is p**retry_limit: p**5 for retry_limit=5 -- not p**6 (5 retries
    after a first attempt) nor p**4."""
    p, n = 0.5, 3000
    lost, attempts, drawn = _message_loss("broadcast", p, n)
    assert attempts == n
    ci = binomtest(lost, n).proportion_ci(confidence_level=0.99)
    assert ci.low <= p <= ci.high
    assert drawn == lost

    lost, attempts, drawn = _message_loss("unicast", p, n, retry_limit=5)
    frame_ci = binomtest(drawn, attempts).proportion_ci(confidence_level=0.99)
    assert frame_ci.low <= p <= frame_ci.high              # the frame loss is still p per attempt
    ci = binomtest(lost, n).proportion_ci(confidence_level=0.99)
    assert ci.low <= p ** 5 <= ci.high
    assert not ci.low <= p ** 6 <= ci.high
    assert not ci.low <= p ** 4 <= ci.high
    # the default retry limit (7 attempts) hides a frame loss of 0.5 almost completely
    lost7, _, _ = _message_loss("unicast", p, n)
    assert binomtest(lost7, n).proportion_ci(confidence_level=0.99).low <= p ** 7 < 0.01


def test_star_is_not_broadcast():
    sim = Simulation(seed=1)
    net = WLAN80211b(sim, "w")
    a = net.attach("a")
    net.attach("b", position=(10.0, 0.0))
    with pytest.raises(ValueError, match=r"unknown destination node '\*'"):
        a.send("*", None, 800)      # '*' is how the trace writes BROADCAST, not an address
