"""Jitterbug's DC servo by exact analysis: expected cost against delay and against period.

The servo G(s) = 1000 / (s (s + 1)) of the Jitterbug manual and of TrueTime, driven by
unit-intensity white noise at its input, under a discrete PD controller
u_k = -K (y_k + Td (y_k - y_{k-1}) / h) with K = 1.5, Td = 0.035 s; the cost is
J = E ∫ y^2 + 1e-6 u^2 dt per second.  No simulation and no Monte Carlo: every number is
the exact stationary expected cost (netcosim.lq, docs/lq.md).

* cost against a constant sampling-to-actuation delay tau in [0, h) (h = 10 ms):
  the periodic analysis (``lq.periodic_cost``);
* cost against a random delay, uniform on the grid 0, delta, ..., tau_max (delta = h/20):
  Jitterbug's timing model (``lq.TimingModel``), drawn over the constant-delay curve;
* cost against the period h with no delay and with a delay of h/2.

Run: ``python -m netcosim.experiments.jitterbug_servo`` (PNG + Parquet under
results/jitterbug_servo/).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from netcosim import lq

K, TD = 1.5, 0.035
H = 0.010
A = np.array([[0.0, 1.0], [0.0, -1.0]])
B = np.array([[0.0], [1000.0]])
C = np.array([[1.0, 0.0]])
R_C = B @ B.T
Q_C = np.diag([1.0, 0.0, 1e-6])


def servo_loop(h: float = H) -> lq.Interconnection:
    """Plant 1, sampler 2, PD controller 3 (its state: the previous measurement)."""
    plant = lq.ContinuousSystem(A, B, C, R_c=R_C, Q_c=Q_C)
    pd_ = lq.DiscreteSystem([[0.0]], [[1.0]], [[K * TD / h]], [[-K * (1 + TD / h)]])
    return (lq.Interconnection().add(1, plant, inputs=3)
            .add(2, lq.DiscreteSystem.gain(1.0), inputs=1)
            .add(3, pd_, inputs=2))


def constant_delay_cost(tau: float, h: float = H) -> float:
    """Stationary cost per second with the control applied *tau* s after each sample."""
    sched = [lq.Execute(2), lq.Wait(tau), lq.Execute(3), lq.Wait(h - tau)]
    return lq.periodic_cost(servo_loop(h), sched).cost_rate


def random_delay_cost(steps_max: int, grain: int = 20, h: float = H) -> float:
    """Stationary cost per second with a delay uniform on {0, 1, ..., steps_max} * h / grain."""
    pmf = np.zeros(grain + 1)
    pmf[:steps_max + 1] = 1.0 / (steps_max + 1)
    tm = lq.TimingModel(servo_loop(h), delta=h / grain, period=h)
    tm.add_node(1, delay=pmf, next=2, execute=2).add_node(2, execute=3)
    return tm.cost().cost_rate


def main(outdir: str = "results/jitterbug_servo", quick: bool = False) -> dict[str, pd.DataFrame]:
    """Both sweeps; writes ``delay.parquet``, ``period.parquet`` and ``jitterbug_servo.png``
    to *outdir*; returns the two tables."""
    import matplotlib.pyplot as plt
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    grain = 20
    steps = range(0, grain, 4 if quick else 1)
    delay = pd.DataFrame({"tau_s": [k * H / grain for k in steps],
                          "constant_delay": [constant_delay_cost(k * H / grain) for k in steps],
                          "uniform_delay_up_to_tau": [random_delay_cost(k, grain) for k in steps]})
    periods = np.linspace(0.002, 0.03, 6 if quick else 15)
    period = pd.DataFrame({"h_s": periods,
                           "no_delay": [constant_delay_cost(0.0, h) for h in periods],
                           "delay_h_over_2": [constant_delay_cost(h / 2, h) for h in periods]})
    delay.to_parquet(out / "delay.parquet")
    period.to_parquet(out / "period.parquet")

    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    ax[0].plot(delay["tau_s"] * 1e3, delay["constant_delay"], "o-", label="constant delay tau")
    ax[0].plot(delay["tau_s"] * 1e3, delay["uniform_delay_up_to_tau"], "s--", label="uniform random delay in [0, tau]")
    ax[0].set_xlabel("delay tau (ms)")
    ax[0].set_ylabel("expected cost per second J")
    ax[0].set_title(f"h = {H * 1e3:g} ms")
    ax[0].legend(fontsize=8)
    for col, lab in (("no_delay", "no delay"), ("delay_h_over_2", "delay h/2")):
        finite = np.isfinite(period[col])
        ax[1].plot(period["h_s"][finite] * 1e3, period[col][finite], "o-", label=lab)
    ax[1].set_xlabel("period h (ms)")
    ax[1].set_ylabel("expected cost per second J")
    ax[1].set_yscale("log")
    ax[1].legend(fontsize=8)
    fig.suptitle("DC servo 1000/(s(s+1)) under PD control: exact stationary cost (netcosim.lq)")
    fig.tight_layout()
    fig.savefig(out / "jitterbug_servo.png", dpi=120)
    plt.close(fig)
    return {"delay": delay, "period": period}


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/jitterbug_servo", quick="fewer delays and periods").parse_args()
    for name, table in main(a.outdir, quick=a.quick).items():
        print(name)
        print(table.to_string(index=False))
