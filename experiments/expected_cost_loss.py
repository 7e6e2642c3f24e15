"""Networked DC servo under message loss: the exact expected cost against the loss probability.

The servo 1000/(s(s+1)) of Jitterbug and TrueTime, driven by unit-intensity white noise
at its input (R_c = B B^T), under a PD controller (K = 0.5, Td = 0.035 s, h = 10 ms;
Jitterbug's K = 1.5 loses mean-square stability near 15 % loss), closed over an
IdealLink at 1 Mbit/s whose frames are lost independently with probability p
(Bernoulli, both directions).  Cost J = E ∫ y² + 1e-6 u² dt, per second.
The sensor node samples at kh and sends after 0.5 ms of CPU time; the 500-bit message
arrives 0.5 ms later; the controller node computes at once (the PD update) and sends after
1 ms; the control arrives 0.5 ms later and is written after 0.5 ms: actuation at kh + 3 ms.
A lost message executes nothing downstream (hold).  Two channels with the same mean
loss p: independent losses (Bernoulli), and bursts (Gilbert–Elliott, lost in the bad
state, kept in the good one, mean burst length 2 frames: p_bg = 0.5, p_gb = p p_bg/(1-p)),
each direction its own channel as in the simulation.  Bursts of the same mean loss cost
far more, and the loop loses mean-square stability under them between 17.5 and 20 %
(under independent losses it is stable over the whole range); the Monte Carlo is run only
where the loop is stable (elsewhere its sample mean means nothing: ``stable`` is False).

* exact curve: ``netcosim.lq.loss_cost_curve`` -- the loop as a Markov jump linear system
  (per period: sampler at 0, controller at 1 ms if the measurement arrived, actuator at
  3 ms if the control arrived too; with bursts the channels' states are part of the
  mode), no simulation, no Monte Carlo;
* Monte Carlo: the ordinary netcosim simulation (tasks, network, loss draws) with the
  plant integrated by ``NoisyZOH`` (exact noisy step, per-run cost exact given each
  interval's start state); per run the cost per second over [0.5 s, T]; the mean over
  the runs with its 99 % confidence band, drawn under the exact curve.

Run: ``python -m netcosim.experiments.expected_cost_loss`` (PNG + Parquet under
results/expected_cost_loss/; --quick: 3 loss values per channel, 12 runs of 1 s; full: 11 values, 400 runs of 4 s).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from netcosim import GilbertElliott, IdealLink, Simulation, lq
from netcosim.plant import NoisyZOH
from netcosim.plants.dc_servo import DCServo

H = 0.010                 # sampling period (s)
K, TD = 0.5, 0.035        # PD gain (V/rad), derivative time (s)
IO_EXEC = 0.0005          # CPU time of sampling and of actuation (s)
CONTROL_EXEC = 0.001      # CPU time of the controller (s)
FRAME_BITS = 500          # message size (bits)
DATA_RATE = 1e6           # bit/s: 0.5 ms per message
A = np.array([[0.0, 1.0], [0.0, -1.0]])
B = np.array([[0.0], [1000.0]])
R_C = B @ B.T             # unit-intensity white noise at the input
Q_C = np.diag([1.0, 0.0, 1e-6])   # on [x1, x2, u]: y² + 1e-6 u²
#: the period's stages: sampler at 0, controller at 1 ms, actuator at 3 ms
STAGES = (lq.Stage(0.0, "sampler", lossy=False), lq.Stage(0.001, "ctrl"), lq.Stage(0.003, "act"))
LOSSES = tuple(round(0.025 * k, 3) for k in range(11))   # 0, 0.025, ..., 0.25
BURST = 2.0               # mean length of a loss burst (frames) of the bursty channel
WARMUP = 0.5              # s discarded from each Monte-Carlo run (the transient: < 1e-5 of J left)


def servo_model(noise: bool = True) -> lq.Interconnection:
    """The loop as a linear-quadratic model: plant, sampler, PD controller (state: the
    previous measurement), actuator (a hold); ``noise=False``: no plant noise."""
    plant = lq.ContinuousSystem(A, B, [[1.0, 0.0]], R_c=R_C if noise else None, Q_c=Q_C)
    pd_ = lq.DiscreteSystem([[0.0]], [[1.0]], [[K * TD / H]], [[-K * (1 + TD / H)]])
    return (lq.Interconnection().add("plant", plant, inputs="act")
            .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
            .add("ctrl", pd_, inputs="sampler")
            .add("act", lq.DiscreteSystem.gain(1.0), inputs="ctrl"))


def bursty(p: float) -> GilbertElliott:
    """The Gilbert–Elliott channel of mean loss *p* with mean bursts of :data:`BURST` frames."""
    p_bg = 1.0 / BURST
    return GilbertElliott(p_gb=p * p_bg / (1.0 - p), p_bg=p_bg, loss_good=0.0, loss_bad=1.0)


CHANNELS = {"bernoulli": float, "gilbert_elliott": bursty}


def expected_cost_curve(losses: Any = LOSSES, channel: str = "bernoulli") -> np.ndarray:
    """The exact stationary expected cost per second for each mean loss probability of
    *losses* on *channel* (a key of :data:`CHANNELS`), in one call."""
    return lq.loss_cost_curve(servo_model(), H, STAGES, [CHANNELS[channel](p) for p in losses])


class PD:
    """u = -K (y + Td (y - y_prev) / h), y_prev the last measurement it was run on."""

    def __init__(self) -> None:
        self.prev = 0.0

    def __call__(self, y: float) -> float:
        u = K * TD / H * self.prev - K * (1 + TD / H) * y
        self.prev = y
        return u


def build(seed: int, loss: Any, *, noise_seed: int | None = None, noise: bool = True,
          x0: Any = (0.0, 0.0)) -> tuple[Simulation, lq.ExpectedCost, NoisyZOH]:
    """The networked loop as an ordinary simulation, with an :class:`~netcosim.lq.ExpectedCost`
    driven by its tasks.  ``seed``: the simulation's seed (loss draws; the plant noise too
    unless ``noise_seed``); ``loss``: the links' frame loss (a probability or a loss
    model, each directed link its own channel); ``noise``: False
    for a noise-free plant; ``x0``: the plant's initial state (the model's mean is set to it)."""
    sim = Simulation(seed=seed)
    zoh = NoisyZOH(R_C if noise else None, Q_C, seed=noise_seed)
    plant = sim.plant(DCServo(), x0=list(x0), name="servo", integrator=zoh, log="none")
    net = IdealLink(sim, "net", data_rate=DATA_RATE, loss=loss)
    sensor, controller = sim.node("sensor"), sim.node("controller")
    s_if, c_if = net.attach(sensor), net.attach(controller)
    ec = lq.ExpectedCost(sim, servo_model(noise))
    if any(x0):
        ec.propagator.impulse(list(x0), system="plant")
    y_port, u_port = plant.output(0), plant.input(0)
    law = PD()

    @sensor.periodic(period=H, priority=2, name="sample")
    def sample(ctx):
        y = ctx.read(y_port)
        ec.execute("sampler")
        yield ctx.execute(IO_EXEC)
        ctx.send("controller", y, FRAME_BITS)

    @sensor.aperiodic(priority=1, name="actuate")
    def actuate(ctx):
        u = s_if.mailbox.try_fetch().payload
        yield ctx.execute(IO_EXEC)
        ctx.write(u_port, u)
        ec.execute("act")

    @controller.aperiodic(priority=1, name="pd")
    def control(ctx):
        y = c_if.mailbox.try_fetch().payload
        u = law(y)
        ec.execute("ctrl")
        yield ctx.execute(CONTROL_EXEC)
        ctx.send("sensor", u, FRAME_BITS)

    s_if.on_receive(actuate)
    c_if.on_receive(control)
    return sim, ec, zoh


def scenario(params: dict, seed: int) -> dict[str, float]:
    """A sweep scenario: ``params = {"loss": p, "duration": T}``; returns the run's
    ``expected_cost`` (exact over the plant noise, along this run's schedule and losses) and
    ``cost`` (this noise realisation's, exact given each interval's start state)."""
    T = float(params.get("duration", 1.0))
    sim, ec, zoh = build(seed, params["loss"])
    sim.run(until=T)
    return {"expected_cost": ec.cost_until(T), "cost": zoh.cost}


def monte_carlo(loss: Any, runs: int, duration: float, warmup: float = WARMUP, first_seed: int = 0) -> np.ndarray:
    """Per run (seeds first_seed, ...): the cost per second over [warmup, duration] of the
    noisy simulation, and the exact expected one along the same run's schedule; shape
    (runs, 2)."""
    out = np.empty((runs, 2))
    for i in range(runs):
        sim, ec, zoh = build(first_seed + i, loss)
        sim.run(until=warmup)
        c0, e0 = zoh.cost, ec.cost_until(warmup)
        sim.run(until=duration)
        out[i] = ((zoh.cost - c0) / (duration - warmup), (ec.cost_until(duration) - e0) / (duration - warmup))
    return out


def ci99(samples: np.ndarray) -> tuple[float, float]:
    """Mean and half-width of its 99 % confidence interval (2.576 s / sqrt(N))."""
    s = np.asarray(samples, dtype=float)
    return float(s.mean()), float(2.576 * s.std(ddof=1) / math.sqrt(s.size))


def main(outdir: str = "results/expected_cost_loss", quick: bool = False) -> pd.DataFrame:
    """The exact curves over :data:`LOSSES` on both channels and their Monte-Carlo sweeps; writes
    ``expected_cost_loss.parquet`` and ``expected_cost_loss.png``; returns the table."""
    import matplotlib.pyplot as plt
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    losses = (0.0, 0.05, 0.1) if quick else LOSSES
    runs, duration = (12, 1.0) if quick else (400, 4.0)
    rows = []
    for c, (channel, make) in enumerate(CHANNELS.items()):
        exact = expected_cost_curve(losses, channel)
        for k, (p, J) in enumerate(zip(losses, exact)):
            row = {"channel": channel, "loss": p, "expected_cost_rate": J, "stable": bool(math.isfinite(J)),
                   "mc_mean": math.nan, "mc_ci99": math.nan, "along_schedule_mean": math.nan, "runs": 0,
                   "duration_s": duration}
            if row["stable"]:
                mc = monte_carlo(make(p), runs, duration, first_seed=10_000 * k + 500_000 * c)   # independent seeds
                m, w = ci99(mc[:, 0])
                row.update(mc_mean=m, mc_ci99=w, along_schedule_mean=float(mc[:, 1].mean()), runs=runs)
            rows.append(row)
    table = pd.DataFrame(rows)
    table.to_parquet(out / "expected_cost_loss.parquet")
    fig, ax = plt.subplots(figsize=(6, 4))
    for (channel, part), color in zip(table.groupby("channel", sort=False), ("C0", "C1")):
        name = "independent" if channel == "bernoulli" else f"bursts of {BURST:g}"
        ax.fill_between(part["loss"], part["mc_mean"] - part["mc_ci99"], part["mc_mean"] + part["mc_ci99"],
                        color=color, alpha=0.25, label=f"{name}: Monte Carlo, {runs} runs, 99 % CI")
        ax.plot(part["loss"], part["mc_mean"], "x", color=color)
        ax.plot(part["loss"], part["expected_cost_rate"], "o-", color=color, label=f"{name}: exact (MJLS)")
        if not part["stable"].all():
            ax.axvline(part.loc[~part["stable"], "loss"].min(), color=color, ls=":",
                       label=f"{name}: not mean-square stable from here")
    ax.set_xlabel("mean message loss probability p (each direction)")
    ax.set_ylabel("cost per second  E[y² + 1e-6 u²]")
    ax.set_title("Networked DC servo, PD, h = 10 ms: cost against loss")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "expected_cost_loss.png", dpi=120)
    plt.close(fig)
    return table


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/expected_cost_loss",
                          quick="3 loss values per channel, 12 runs of 1 s").parse_args()
    print(main(a.outdir, quick=a.quick).to_string(index=False))
