"""Exact expected-cost curve against a Monte-Carlo sweep of the same loss setup: wall time.

The networked DC servo of ``experiments/expected_cost_loss.py`` (PD, h = 10 ms, IdealLink
with Bernoulli frame loss p in both directions) over 11 loss probabilities p = 0, 0.025,
..., 0.25:

* **exact**: ``lq.loss_cost_curve`` -- the stationary expected cost per second, the loop
  as a Markov jump linear system (no simulation); timed over the 11 values;
* **Monte Carlo**: per p, ``RUNS`` runs of the ordinary simulation (tasks, network, loss
  draws, ``NoisyZOH`` plant noise) of ``DURATION`` s, cost per second over [0.5 s, T];
  timed, with the 99 % half-width each p reached (``2.576 s / sqrt(N)``).

The Monte Carlo cannot reach the exact curve's precision (rounding); to compare like with
like, the number of runs N_w that each p needs for a 99 % half-width of ``TARGET`` (1 %)
of the cost is computed from the measured spread, ``N_w = (2.576 s / (TARGET J))^2``, and
its wall time projected from the measured time per run.  Reported: the measured times of
both, the measured ratio at the widths the Monte Carlo reached, and the projected ratio at
1 %.  Run ``python -m benchmarks.expected_cost`` (``--runs N`` to change RUNS).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import pandas as pd

from netcosim.experiments import expected_cost_loss as ecl

RUNS = 200
DURATION = 2.5
TARGET = 0.01


def main(runs: int = RUNS, duration: float = DURATION) -> pd.DataFrame:
    """Both sweeps; prints and returns the per-p table."""
    losses = ecl.LOSSES
    t0 = time.perf_counter()
    exact = ecl.expected_cost_curve(losses)
    t_exact = time.perf_counter() - t0
    rows = []
    t_mc = 0.0
    for k, (p, J) in enumerate(zip(losses, exact)):
        t0 = time.perf_counter()
        mc = ecl.monte_carlo(p, runs, duration, first_seed=10_000 * k)[:, 0]   # independent seeds per p
        dt = time.perf_counter() - t0
        t_mc += dt
        mean, half = ecl.ci99(mc)
        s = float(mc.std(ddof=1))
        n_w = int(np.ceil((2.576 * s / (TARGET * J)) ** 2))
        rows.append({"loss": p, "exact": J, "mc_mean": mean, "mc_ci99": half, "ci99_rel": half / J,
                     "inside": abs(mean - J) <= half, "mc_s": dt, "runs_for_1pct": n_w,
                     "projected_s_for_1pct": n_w * dt / runs})
    table = pd.DataFrame(rows)
    proj = float(table["projected_s_for_1pct"].sum())
    print(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    print(f"\nexact curve, 11 losses: {t_exact:.3f} s wall")
    print(f"Monte Carlo, {runs} runs x {duration} s per loss: {t_mc:.1f} s wall "
          f"(99 % half-width {table['ci99_rel'].min():.0%}..{table['ci99_rel'].max():.0%} of J); "
          f"ratio {t_mc / t_exact:.0f}")
    print(f"Monte Carlo to a 99 % half-width of {TARGET:.0%} (projected from the measured time per run and "
          f"spread): {table['runs_for_1pct'].sum()} runs, {proj:.0f} s; ratio {proj / t_exact:.3g}")
    return table


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=RUNS, help=f"Monte-Carlo runs per loss (default {RUNS})")
    ap.add_argument("--duration", type=float, default=DURATION, help=f"seconds per run (default {DURATION})")
    a = ap.parse_args()
    main(a.runs, a.duration)
