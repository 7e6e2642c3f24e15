"""Figs. 3.10-3.12: the LAAS Fly-crane experiment of Sec. 3.6 in simulation, offline vs online gain.

The rig (:func:`netcosim.plants.flycrane.configurations.experimental_flycrane`): 1.2 m cables,
robots 1.03 kg, platform 0.338 kg, start ``q_V(0) = (0, 0, 0.4 m, 0, 0, 0)``,
``q_i(0) = 55 deg``.  The planner runs every T = 1.5 s on the load's node and talks to
the three robots over one lossy IEEE 802.11b link (broadcast, no retry: a robot misses
a period's message with probability ``loss``, default 0.1, an assumed indoor WLAN loss;
the thesis reports none).  The plant is the dynamic model (4.10) under the
velocity-tracking force (4.11), ``alpha`` = 30 N s/m (the robots' on-board velocity
controllers).

The waypoint path of Sec. 3.6, switched every ``WAYPOINT_PERIOD`` = 10 s (the thesis
gives only the last switch, at 30 s): lift the load 0.3 m; move it 0.3 m along x; rotate
it 40 deg about z; the final configuration ``q_V(0) + (0.3, 0, 0.3 m, 20, 10, 45 deg)``,
``q_1 = 40``, ``q_2 = 60``, ``q_3 = 70 deg``.  Offline: sparse law (3.10) with the gain
``tau_o_bar(mu_hat)/T`` of (3.25), ``mu_hat`` the largest over the waypoints of (3.19) on
a ball holding every switch's step (the thesis's ball "containing all the configurations
along the path"); a robot holds the last command on a loss.  Online: centralized law
with (3.26) recomputed every sample; a robot zeroes a command older than T.

Run ``python -m netcosim.experiments.ch3_fig3_10_12`` (``--quick``: 5 s per waypoint, fewer
Monte-Carlo samples).  Writes ``fig3_10.png`` (q(t): load position, orientation, cable
angles), ``fig3_11.png`` (robot velocities), ``fig3_12.png`` (tau_o and k per sample),
``series.parquet`` (0.1 s grid), ``samples.parquet`` (one row per period),
``summary.parquet`` (one row per strategy and waypoint) and ``collisions.parquet``
(closest robot-robot approach per strategy) under *outdir*.
"""

from __future__ import annotations

import math
import os

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from netcosim import Simulation, validate
from netcosim.controllers.planner import OfflineGain, OnlineGain
from netcosim.controllers.planner.gain_design import design, estimate_mu
from netcosim.controllers.planner.networked import GridRecorder
from netcosim.controllers.planner.plant_models import VelocityTrackingModel
from netcosim.controllers.planner.sikm import Trajectory
from netcosim.controllers.planner.tasks import DeploymentConfig, PlannerLaw, deploy
from netcosim.errors import ConfigurationError
from netcosim.plants.flycrane.configurations import experimental_flycrane

T = 1.5
#: Seconds between waypoint switches (the thesis assigns the final one at 30 s).
WAYPOINT_PERIOD = 10.0
#: Per-receiver frame loss probability of the broadcast link (assumed; not in the thesis).
LOSS = 0.1
ALPHA = 30.0
#: 802.11b rate (bit/s) and execution times (s) as in :mod:`netcosim.controllers.planner.networked`.
DATA_RATE = 1.2e6
EXEC_POSE, EXEC_PLANNER, EXEC_ROBOT = 0.5e-3, 5e-3, 1e-3
SAMPLE_DT = 0.1
STRATEGIES = ("offline", "online")
LABELS = ("alpha_1", "alpha_2", "alpha_3", "x_V", "y_V", "z_V", "roll_V", "pitch_V", "yaw_V")


def waypoints(system=None) -> list[np.ndarray]:
    """The four references of Sec. 3.6 (rad, m), in order."""
    s = system or experimental_flycrane()
    a0, V0 = [55.0] * 3, np.array([0, 0, 0.4, 0, 0, 0], dtype=float)
    lift = V0 + [0, 0, 0.3, 0, 0, 0]
    move = lift + [0.3, 0, 0, 0, 0, 0]
    rot = move + [0, 0, 0, 0, 0, 40]
    final = V0 + [0.3, 0, 0.3, 20, 10, 45]
    return [s.check_configuration(s.q_from(a, v), f"waypoint {j}") for j, (a, v) in
            enumerate([(a0, lift), (a0, move), (a0, rot), ([40, 60, 70], final)])]


def path(wps: list[np.ndarray], period: float) -> Trajectory:
    """Piecewise-constant reference: waypoint j from ``j * period`` s (rate 0)."""
    def q(t):
        return wps[min(int(math.floor(t / period + 1e-9)), len(wps) - 1)]
    return Trajectory(q, lambda t: np.zeros_like(wps[0]))


def offline_gain(system, q0, wps, n_mu: int, seed: int = 0) -> tuple[float, float, float]:
    """``(k, mu_hat, radius)``: (3.25) with the largest ``mu_hat`` (3.19) over the
    waypoints, each on the ball of radius 1.05 x the largest switch step."""
    prev = [q0] + wps[:-1]
    r = 1.05 * max(float(np.linalg.norm(b - a)) for a, b in zip(prev, wps))
    mu = max(estimate_mu(system, w, r, n_samples=n_mu, seed=seed).mu_hat for w in wps)
    return float(design(mu).gain(T)), float(mu), r


def simulate(strategy: str, k_off: float, period: float, loss: float = LOSS, seed: int = 0):
    """One run of *strategy* (``"offline"`` with gain *k_off* in 1/s, or ``"online"``),
    waypoints switched every *period* s, per-receiver frame loss probability *loss*,
    root seed *seed*; returns ``(series, samples)`` DataFrames (0.1 s grid, per period)."""
    from netcosim.network import Bernoulli, WLAN80211b
    if strategy not in STRATEGIES:
        raise ConfigurationError(f"strategy must be one of {STRATEGIES}, got {strategy!r}")
    loss = validate.probability(loss, "loss (per-receiver frame loss probability)", type_error=ConfigurationError)
    period = validate.positive(period, "waypoint period (s)", kind="a positive number of seconds",
                               type_error=ConfigurationError)
    system = experimental_flycrane()
    q0, wps = system.q_nominal, waypoints(system)
    sim = Simulation(seed)
    net = WLAN80211b(sim, "wlan", data_rate=DATA_RATE, retry_limit=6, loss=Bernoulli(loss) if loss > 0 else None)
    online = strategy == "online"
    model = VelocityTrackingModel(ALPHA)
    cfg = DeploymentConfig(T, PlannerLaw(OnlineGain() if online else OfflineGain(k_off), trajectory=path(wps, period)),
                           architecture="centralized" if online else "sparse",
                           exec_pivot=EXEC_PLANNER if online else EXEC_POSE, exec_robot=EXEC_ROBOT,
                           on_loss="zero" if online else "hold", plant=model, messaging="broadcast",
                           log_interval=None)
    rec = GridRecorder(model.integrator(), SAMPLE_DT, system.m)
    dep = deploy(sim, system, q0, cfg, network=net, integrator=rec)
    rec.start(dep.plant)
    sim.run(len(wps) * period + 2 * T)
    t, q, u = rec.arrays()
    qr = np.array([path(wps, period).q(tk) for tk in t])
    series = pd.DataFrame({"strategy": strategy, "t": t, "waypoint": np.minimum(np.floor(t / period + 1e-9), 3)})
    for i, nm in enumerate(LABELS):
        series[nm] = q[:, i]
        series[nm + "_ref"] = qr[:, i]
    for j in range(u.shape[1]):
        series[f"u{j}"] = u[:, j]
    series["err"] = np.linalg.norm(q - qr, axis=1)
    samples = dep.to_pandas()
    samples.insert(0, "strategy", strategy)
    samples["tau_o"] = samples["k"] * T
    return series, samples


def run(quick: bool = False, loss: float = LOSS, seed: int = 0):
    """Both strategies; returns ``(series, samples, summary)``."""
    loss = validate.probability(loss, "loss (per-receiver frame loss probability)", type_error=ConfigurationError)
    period = 5.0 if quick else WAYPOINT_PERIOD
    system = experimental_flycrane()
    wps = waypoints(system)
    k_off, mu, r = offline_gain(system, system.q_nominal, wps, n_mu=30 if quick else 150, seed=seed)
    series, samples, summ = [], [], []
    for strategy in STRATEGIES:
        s, h = simulate(strategy, k_off, period, loss, seed)
        if strategy == "offline":
            h["k"] = k_off
            h["tau_o"] = k_off * T
        series.append(s)
        samples.append(h)
        for j in range(len(wps)):
            seg = s[(s.t >= j * period) & (s.t < (j + 1) * period + (2 * T if j == len(wps) - 1 else 0))]
            speed = float(np.abs(seg.filter(regex=r"^u\d+$").values).max())
            summ.append(dict(strategy=strategy, waypoint=j, t_switch=j * period, err_start=float(seg.err.iloc[0]),
                             err_end=float(seg.err.iloc[-1]), max_speed=speed, k_offline=k_off, mu_hat=mu, radius=r,
                             loss=loss))
    return pd.concat(series, ignore_index=True), pd.concat(samples, ignore_index=True), pd.DataFrame(summ)


STYLES = {"offline": "b-", "online": "r-"}


def plot(series: pd.DataFrame, samples: pd.DataFrame, outdir: str) -> None:
    """Figs. 3.10, 3.11, 3.12 into *outdir*."""
    deg = set(LABELS) - {"x_V", "y_V", "z_V"}
    order = ["x_V", "y_V", "z_V", "roll_V", "pitch_V", "yaw_V", "alpha_1", "alpha_2", "alpha_3"]
    fig, axes = plt.subplots(3, 3, figsize=(12, 8), sharex=True)
    for ax, nm in zip(axes.flat, order):
        f = np.degrees if nm in deg else (lambda x: x)
        for strategy, st in STYLES.items():
            d = series[series.strategy == strategy]
            ax.plot(d.t, f(d[nm]), st, label=strategy)
        ax.plot(d.t, f(d[nm + "_ref"]), "k--", lw=0.8, label="reference")
        ax.set_ylabel(nm + (" [deg]" if nm in deg else " [m]"))
    axes[0, 0].legend(fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    fig.suptitle(f"Fig. 3.10: q(t), rig, T = {T} s, 802.11b loss {series.attrs.get('loss', LOSS):g}")
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig3_10.png"), dpi=110)
    plt.close(fig)
    fig, axes = plt.subplots(3, 3, figsize=(12, 8), sharex=True)
    for i in range(3):
        for c in range(3):
            for strategy, st in STYLES.items():
                d = series[series.strategy == strategy]
                axes[i, c].plot(d.t, d[f"u{3 * i + c}"], st, label=strategy)
            axes[i, c].set_ylabel(f"robot {i + 1} p_dot_{'xyz'[c]} [m/s]")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle("Fig. 3.11: desired robot velocities (piecewise constant, period T)")
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig3_11.png"), dpi=110)
    plt.close(fig)
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for strategy, st in STYLES.items():
        d = samples[samples.strategy == strategy]
        axes[0].step(d.t, d.tau_o, st, where="post", label=strategy)
        axes[1].step(d.t, d.k, st, where="post", label=strategy)
    axes[0].axhline(1.0, color="k", lw=0.5)
    axes[1].axhline(1 / T, color="k", lw=0.5)
    axes[0].set_ylabel("tau_o")
    axes[1].set_ylabel("k [1/s]")
    axes[1].set_xlabel("t [s]")
    axes[0].legend()
    fig.suptitle("Fig. 3.12: optimal flow time tau_o and gain k")
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig3_12.png"), dpi=110)
    plt.close(fig)


def clearance(series: pd.DataFrame) -> pd.DataFrame:
    """Closest robot-robot approach of each strategy's run along its recorded
    configuration series (dense grid, chord error bounded)."""
    from netcosim.controllers.planner.clearance import trajectory_clearance
    system = experimental_flycrane()
    return pd.DataFrame([dict(strategy=s, **trajectory_clearance(system, d.t, d[list(LABELS)]).as_row())
                         for s, d in series.groupby("strategy", sort=False)])


def main(outdir: str = "results/ch3_fig3_10_12", quick: bool = False, loss: float = LOSS) -> pd.DataFrame:
    """Run, save the figures and tables; return the summary."""
    os.makedirs(outdir, exist_ok=True)
    series, samples, summary = run(quick, loss)
    series.to_parquet(os.path.join(outdir, "series.parquet"))
    samples.to_parquet(os.path.join(outdir, "samples.parquet"))
    summary.to_parquet(os.path.join(outdir, "summary.parquet"))
    clearance(series).to_parquet(os.path.join(outdir, "collisions.parquet"))
    series.attrs["loss"] = loss
    plot(series, samples, outdir)
    return summary


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    p = experiment_parser(__doc__, "results/ch3_fig3_10_12")
    p.add_argument("--loss", type=float, default=LOSS, help=f"per-receiver frame loss probability (default {LOSS})")
    a = p.parse_args()
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(main(a.outdir, a.quick, a.loss))
