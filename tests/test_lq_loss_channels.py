"""Loss by expectation on channels with memory and on retrying links (netcosim.lq.loss_cost
with Gilbert–Elliott bursts, shared links, retries): against a Markov jump linear system
derived here independently -- per period, every path of frame outcomes enumerated with
the channel's state, the period-start second moments per channel state solved as one
linear equation -- and against a Monte Carlo of the ordinary simulation whose IdealLink
draws the same Gilbert–Elliott channel."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from lq_reference import period_map  # noqa: E402  (tests/ is on the path)

from netcosim import Bernoulli, GilbertElliott, TraceLoss, lq
from netcosim.errors import ConfigurationError, ConfigurationTypeError
from netcosim.experiments import expected_cost_loss as ecl
from netcosim.network import AnyLoss

H = ecl.H


def _paths(stages, chains, links, cs):
    """Every way one period can go from the joint channel state *cs*: (probability, the
    sequence of ("x", system) / ("w", seconds) steps, the channel state at the period's end).
    Written frame by frame, without the timing-model machinery."""
    out = []

    def walk(i, t, cs, prob, seq):
        if i == len(stages):
            out.append((prob, seq + [("w", H - t)], cs))
            return
        st = stages[i]
        t_i = t + (st.at - stages[i - 1].at if i else st.at)
        seq = seq + ([("w", t_i - t)] if t_i > t else [])
        if not st.lossy:
            walk(i + 1, t_i, cs, prob, seq + [("x", e) for e in st.execute])
            return
        k = links.index(st.link if st.link is not None else i)
        P, lo = chains[k]

        def attempt(j, t_a, cs, prob, seq):
            c = cs[k]
            for c2 in range(P.shape[0]):
                moved = cs[:k] + (c2,) + cs[k + 1:]
                ok, bad = prob * (1 - lo[c]) * P[c, c2], prob * lo[c] * P[c, c2]
                if ok > 0:
                    walk(i + 1, t_a, moved, ok, seq + [("x", e) for e in st.execute])
                if bad > 0:
                    if j < st.retries:
                        attempt(j + 1, t_a + st.retry_delay, moved, bad,
                                seq + ([("w", st.retry_delay)] if st.retry_delay else []))
                    else:
                        out.append((bad, seq + [("w", H - t_a)], moved))

        # a later stage is shifted by this stage's retries: the offsets are relative
        attempt(0, t_i, cs, prob, seq)

    walk(0, 0.0, cs, 1.0, [])
    return out


def _mjls(stages, chains, links, model):
    d = model.dynamics()
    N = d.size
    joint = list(itertools.product(*(range(P.shape[0]) for P, _ in chains)))
    C = len(joint)
    # the channel's stationary distribution at period starts, and per path the maps
    trans = np.zeros((C, C))
    per = {}
    for a, cs in enumerate(joint):
        per[a] = []
        for prob, seq, end in _paths(stages, chains, links, cs):
            F, W, G, c = period_map(model, seq)
            b = joint.index(end)
            trans[a, b] += prob
            per[a].append((prob, F, W, G, c, b))
    A = np.vstack([trans.T - np.eye(C), np.ones((1, C))])
    pi = np.linalg.lstsq(A, np.r_[np.zeros(C), 1.0], rcond=None)[0]
    lhs = np.eye(C * N * N)
    rhs = np.zeros(C * N * N)
    for a in range(C):
        for prob, F, W, _, _, b in per[a]:
            lhs[b * N * N:(b + 1) * N * N, a * N * N:(a + 1) * N * N] -= prob * np.kron(F, F)
            rhs[b * N * N:(b + 1) * N * N] += prob * pi[a] * W.reshape(-1)
    X = np.linalg.solve(lhs, rhs).reshape(C, N, N)
    return sum(prob * (float(np.sum(G * X[a])) + pi[a] * c) for a in range(C)
               for prob, _, _, G, c, _ in per[a]) / H


def _chain(m):
    ch = m.markov()
    return ch.transition, ch.loss


@pytest.mark.parametrize("case", ["bursts", "shared_link", "retries", "any"])
def test_loss_cost_with_memory_and_retries_equals_the_mjls(case):
    model = ecl.servo_model()
    ge = GilbertElliott(p_gb=0.02, p_bg=0.5, loss_good=0.01, loss_bad=0.8)
    stages = list(ecl.STAGES)
    if case == "bursts":                  # each direction its own bursty channel
        loss, links = ge, [1, 2]
        chains = [_chain(ge), _chain(ge)]
    elif case == "shared_link":           # both messages on one channel: it steps twice a period
        stages = [stages[0], lq.Stage(0.001, "ctrl", link="radio"), lq.Stage(0.003, "act", link="radio")]
        loss, links, chains = ge, ["radio"], [_chain(ge)]
    elif case == "retries":               # up to 2 retries 0.5 ms apart, shifting the actuator
        stages = [stages[0], lq.Stage(0.001, "ctrl", link="up", retries=2, retry_delay=0.0005),
                  lq.Stage(0.003, "act", link="down", retries=1, retry_delay=0.001)]
        down = GilbertElliott(p_gb=0.1, p_bg=0.5)
        loss, links, chains = {"up": ge, "down": down}, ["up", "down"], [_chain(ge), _chain(down)]
    else:                                 # a bursty channel and an independent one at once
        m = AnyLoss([ge, Bernoulli(0.05)])
        loss, links, chains = m, [1, 2], [_chain(m), _chain(m)]
    got = lq.loss_cost(model, H, stages, loss)
    assert got.stable and got.period == H       # the period as given, not steps * grain
    assert got.cost_rate == pytest.approx(_mjls(stages, chains, links, model), rel=1e-9)


def test_bursts_cost_more_than_independent_losses_of_the_same_mean():
    b = ecl.expected_cost_curve([0.1])[0]
    g = ecl.expected_cost_curve([0.1], "gilbert_elliott")[0]
    assert ecl.bursty(0.1).loss_rate == pytest.approx(0.1, rel=1e-12)
    # one lost message repeats a held control for one period; bursts of 4 hold it for four
    assert g > b * 1.02, (b, g)
    # at zero mean loss both channels are the loss-free loop
    assert ecl.expected_cost_curve([0.0], "gilbert_elliott")[0] == pytest.approx(
        ecl.expected_cost_curve([0.0])[0], rel=1e-12)


def test_retries_without_delay_are_a_message_loss_of_p_to_the_attempts():
    model = ecl.servo_model()
    p = 0.3
    retrying = [ecl.STAGES[0], lq.Stage(0.001, "ctrl", retries=2), lq.Stage(0.003, "act", retries=2)]
    assert lq.loss_cost(model, H, retrying, p).cost_rate == pytest.approx(
        lq.loss_cost(model, H, ecl.STAGES, p ** 3).cost_rate, rel=1e-10)
    # a retry that takes time costs more than one that does not
    late = [ecl.STAGES[0], lq.Stage(0.001, "ctrl", retries=2, retry_delay=0.001),
            lq.Stage(0.003, "act", retries=2, retry_delay=0.001)]
    assert lq.loss_cost(model, H, late, p).cost_rate > lq.loss_cost(model, H, retrying, p).cost_rate


def test_gilbert_elliott_cost_inside_a_monte_carlo_of_the_simulation():
    # the IdealLink draws the same channel per directed link and frame; 100 runs of 2.5 s
    # (bursts give the per-run cost a heavy tail: at 10 % the 99 % CI is +-27 %, at 5 % +-8 %)
    p = 0.05
    mc = ecl.monte_carlo(ecl.bursty(p), 100, 2.5, first_seed=7000)
    exact = ecl.expected_cost_curve([p], "gilbert_elliott")[0]
    mean, half = ecl.ci99(mc[:, 0])
    assert half < 0.10 * exact
    assert abs(mean - exact) <= half, (exact, mean, half)


def test_channels_the_analysis_cannot_take_are_refused_by_name():
    model = ecl.servo_model()
    with pytest.raises(ConfigurationTypeError, match=r"TraceLoss.*ExpectedCost along it"):
        lq.loss_cost(model, H, ecl.STAGES, TraceLoss([0, 1]))
    with pytest.raises(ConfigurationError, match=r"links \['up', 'down'\], given \['up'\]"):
        lq.loss_cost(model, H, [ecl.STAGES[0], lq.Stage(0.001, "ctrl", link="up"),
                                lq.Stage(0.003, "act", link="down")], {"up": 0.1})
    with pytest.raises(ConfigurationError, match="retries and link are for a lossy stage"):
        lq.Stage(0.0, "sampler", lossy=False, retries=1)
    with pytest.raises(ConfigurationError, match=r"with every retry \(0.008 s\), below the period"):
        lq.loss_cost(model, H, [ecl.STAGES[0], lq.Stage(0.003, "ctrl", retries=4, retry_delay=0.002)], 0.1)
    with pytest.raises(ConfigurationError, match=r"loss of link .* \(frame loss probability\) must be a "
                                                 r"probability in \[0, 1\], got 1.5"):
        lq.loss_cost(model, H, ecl.STAGES, 1.5)


def test_the_markov_description_is_what_the_links_draw():
    # 200 000 frames of one link of AnyLoss([bursts, 5 %]): loss rate and lag-1 loss pairs
    # against the chain's stationary values (the mixing is fast: 99 % intervals of ~0.2 %)
    m = AnyLoss([GilbertElliott(p_gb=0.05, p_bg=0.4, loss_good=0.01, loss_bad=0.9), Bernoulli(0.05)])
    ch = m.markov()
    P, lo = ch.transition, ch.loss
    w, v = np.linalg.eig(P.T)
    pi = np.real(v[:, np.argmin(abs(w - 1))])
    pi /= pi.sum()
    rate, pair = float(pi @ lo), float((pi * lo) @ P @ lo)
    link = m.link(np.random.default_rng(11))
    x = np.array([link.lost() for _ in range(200_000)], dtype=float)
    assert x.mean() == pytest.approx(rate, abs=0.003)
    assert float((x[:-1] * x[1:]).mean()) == pytest.approx(pair, abs=0.003)
    assert pair > 1.5 * rate ** 2           # bursts: a loss makes the next loss likelier
    assert ch.consecutive_loss(1) == pytest.approx(float(ch.initial @ lo), rel=1e-12)


def test_the_reported_period_is_the_one_given():
    # the deadbeat integrator of loss_cost's docstring, h = 0.1 s: the grain is found from
    # the offsets (0.05 s here), and 2 * 0.05 would not be the user's 0.1 in every last bit;
    # the cost per period is cost_rate * 0.1, so the period must be exactly the one given
    h = 0.1
    loop = (lq.Interconnection()
            .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=1.0, Q_c=np.diag([1.0, 0.0])), inputs="ctrl")
            .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
            .add("ctrl", lq.DiscreteSystem.gain(-1 / h), inputs="sampler"))
    for stages in ([lq.Stage(0.0, "sampler", lossy=False), lq.Stage(0.0, "ctrl")],
                   [lq.Stage(0.0, "sampler", lossy=False), lq.Stage(0.03, "ctrl")]):
        got = lq.loss_cost(loop, h, stages, 0.2)
        assert got.period == 0.1
        assert got.cost_per_period == got.cost_rate * 0.1
    # J = r h ((1 + 2p) / (3 (1 - 3p)) + 1/2) with no delay (the docstring's closed form)
    assert lq.loss_cost(loop, h, stages[:1] + [lq.Stage(0.0, "ctrl")], 0.2).cost_rate == pytest.approx(
        h * ((1 + 2 * 0.2) / (3 * (1 - 3 * 0.2)) + 0.5), rel=1e-12)
