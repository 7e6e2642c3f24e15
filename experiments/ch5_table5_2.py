"""Table 5.2 and Figs. 5.3, 5.4, 5.5, 5.7: SIKM stability set, optimal gain and period.

All quantities are the closed forms of Propositions 5.4.2-5.4.4 applied to the bound
``z(k, tau) = |1 - k tau| + alpha tau + tau^2 (k^2 mu + k gamma1 + gamma2)`` (5.20).

* Table 5.2 / Fig. 5.7: ``(mu, alpha, gamma1, gamma2) = (0.02, 0.13, 0.1, 0.2)`` (Sec. 5.5);
  optimal offline gains ``k_o(T)`` for T = 0.5, 0.75, 1.5 s, and T = 4 s outside the
  stability set (``tau_CR ~ 1.71 s``).  The thesis prints k = 1.28 for T = 0.75 s;
  Prop. 5.4.4 gives ``k_o = 1/T = 1.333`` there (``mu < 1/2`` and
  ``T < (1 - 2 mu)/gamma1 = 9.6 s``), with ``rho_o = 0.305`` against ``z(1.28, 0.75) =
  0.3404``: 1.28 is a stabilising but not the optimal gain (the thesis reads its gains
  off the plotted curve, Fig. 5.7).  The other rows agree (2 and 0.67).
* Fig. 5.4 / 5.5: three parameter sets with ``mu < 1/2``, ``1/2 < mu < 1``, ``mu > 1``:
  ``tau_s(k)``, ``tau_o(k)``, the curve ``(k_o(tau), tau)``, and the rates
  ``rho_o(k)``, ``rho_o(tau)``.
* Fig. 5.3: the stability region ``0 < T < tau_s(k)`` (an under-estimate of the
  contractive region ``T < T_c(k)``) and the region ``k T > 2`` where Prop. 5.3.4 rules
  contraction out.

Run ``python -m netcosim.experiments.ch5_table5_2``.  Writes ``table5_2.parquet``,
``curves.parquet`` and ``fig5_3.png``, ``fig5_4.png``, ``fig5_5.png``, ``fig5_7.png``.
"""

from __future__ import annotations

import math
import os

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from netcosim.controllers.planner.sikm import (
    SIKMParams,
    in_stability_set,
    k_bar,
    k_o,
    optimal_offline_gain,
    rho_of_k,
    rho_of_tau,
    tau_critical,
    tau_o,
    tau_s,
    z,
)

THESIS = SIKMParams(0.02, 0.13, 0.1, 0.2)
#: Table 5.2 as printed: T [s] -> offline gain [1/s] (None: strategy 2 not feasible).
THESIS_TABLE = {0.5: 2.0, 0.75: 1.28, 1.5: 0.67, 4.0: None}
EXAMPLES = {"mu<1/2": SIKMParams(0.2, 0.13, 0.1, 0.2), "1/2<mu<1": SIKMParams(0.7, 0.13, 0.1, 0.2),
            "mu>1": SIKMParams(1.5, 0.13, 0.1, 0.2)}


def table_5_2(p: SIKMParams = THESIS) -> pd.DataFrame:
    """Optimal offline gains for the periods of Table 5.2, next to the printed values."""
    rows = []
    for T, k_thesis in THESIS_TABLE.items():
        try:
            k = optimal_offline_gain(T, p)
            rho, ok, note = rho_of_tau(T, p), True, ""
        except ValueError as exc:
            k, rho, ok, note = math.nan, z(k_o(T, p), T, p), False, str(exc)
        rows.append(dict(T=T, k_thesis=np.nan if k_thesis is None else k_thesis, k_o=k, rho_o=rho, stable=ok,
                         z_at_thesis_k=np.nan if k_thesis is None else z(k_thesis, T, p),
                         thesis_k_in_stability_set=(k_thesis is not None and in_stability_set(k_thesis, T, p)),
                         tau_CR=tau_critical(p), note=note))
    return pd.DataFrame(rows)


def curves(p: SIKMParams, name: str, k_max: float = 6.0, n: int = 600) -> pd.DataFrame:
    """``tau_s(k)``, ``tau_o(k)``, ``rho_o(k)`` on a k grid and ``k_o(tau)``, ``rho_o(tau)``
    on a tau grid (NaN where undefined: ``k <= alpha`` or ``tau >= 1/gamma1``)."""
    ks = np.linspace(p.alpha * 1.001 + 1e-3, k_max, n)
    ts = np.linspace(1e-3, min(1 / p.gamma1 if p.gamma1 else 10.0, 10.0) * 0.999, n)
    ko, ro = [], []
    for t in ts:
        try:
            ko.append(k_o(t, p))
            ro.append(rho_of_tau(t, p))
        except ValueError:
            ko.append(math.nan)
            ro.append(math.nan)
    return pd.DataFrame(dict(example=name, k=ks, tau_s=[tau_s(k, p) for k in ks], tau_o=[tau_o(k, p) for k in ks],
                             rho_k=[rho_of_k(k, p) for k in ks], tau=ts, k_o=ko, rho_tau=ro))


def convergent(c: pd.DataFrame) -> pd.DataFrame:
    """*c* (from :func:`curves`) with ``rho_k`` and ``rho_tau`` set to NaN where they
    are not below 1: there the bound does not contract (no convergence guaranteed,
    e.g. ``tau >= tau_CR``), so Fig. 5.5 plots the rate only where it is one."""
    c = c.copy()
    for col in ("rho_k", "rho_tau"):
        c.loc[~(c[col] < 1.0), col] = math.nan
    return c


def _plot_region(ax, p, k_max=6.0, t_max=None):
    t_max = t_max or 2.5 * tau_critical(p)
    K, Tt = np.meshgrid(np.linspace(1e-3, k_max, 300), np.linspace(1e-3, t_max, 300))
    ax.contourf(K, Tt, z(K, Tt, p) < 1.0, levels=[0.5, 1.5], colors=["#b6e3b6"])
    c = curves(p, "", k_max)
    ax.plot(c.k, c.tau_s, "g", label="tau_s(k)")
    ax.plot(c.k, c.tau_o, "b", label="tau_o(k)")
    st = c.rho_tau < 1.0  # the optimal-gain curve inside the stability set
    ax.plot(c.k_o[st], c.tau[st], "m--", label="tau(k_o)")
    ax.plot(c.k, 1 / c.k, "k:", lw=0.8, label="tau = 1/k")
    ax.set_xlim(0, k_max)
    ax.set_ylim(0, t_max)
    ax.set_xlabel("k [1/s]")
    ax.set_ylabel("tau, T [s]")


def plot_all(outdir: str, tab: pd.DataFrame) -> None:
    # Fig. 5.3: stability region and the region excluded by Prop. 5.3.4 (k T > 2)
    fig, ax = plt.subplots(figsize=(6, 4.5))
    _plot_region(ax, THESIS)
    K = np.linspace(1e-3, 6, 300)
    ax.fill_between(K, 2 / K, 10, color="#f4b6b6", alpha=0.7, label="k T > 2 (Prop. 5.3.4)")
    ax.set_title("Fig. 5.3: stability set z < 1 (green) under-estimates T < T_c(k)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig5_3.png"), dpi=120)
    plt.close(fig)
    # Fig. 5.4
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    for ax, (name, p) in zip(axes, EXAMPLES.items()):
        _plot_region(ax, p, t_max=3.0)
        ax.set_title(f"{name}: (mu, alpha, g1, g2) = ({p.mu:g}, {p.alpha:g}, {p.gamma1:g}, {p.gamma2:g})",
                     fontsize=9)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig5_4.png"), dpi=120)
    plt.close(fig)
    # Fig. 5.5
    fig, axes = plt.subplots(2, 1, figsize=(7, 7))
    for name, p in EXAMPLES.items():
        c = convergent(curves(p, name))
        axes[0].plot(c.k, c.rho_k, label=name)
        line, = axes[1].plot(c.tau, c.rho_tau, label=name)
        axes[1].axvline(tau_critical(p), color=line.get_color(), lw=0.8, ls=":")
    axes[0].set_xlabel("k [1/s]")
    axes[0].set_ylabel("rho_o(k)")
    axes[1].set_xlabel("tau [s] (dotted: tau_CR, no stabilising gain beyond)")
    axes[1].set_ylabel("rho_o(tau)")
    for ax in axes:
        ax.set_ylim(0, 1.0)
        ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig5_5.png"), dpi=120)
    plt.close(fig)
    # Fig. 5.7 with the Table 5.2 designs
    fig, ax = plt.subplots(figsize=(7, 5))
    _plot_region(ax, THESIS, k_max=3.0, t_max=4.5)
    ok = tab[tab.stable]
    ax.plot(ok.k_o, ok["T"], "ko", label="k_o(T) (Prop. 5.4.4)")
    th = tab[tab.k_thesis.notna()]
    ax.plot(th.k_thesis, th["T"], "rx", ms=9, label="Table 5.2 (printed)")
    ax.axhline(tau_critical(THESIS), color="r", lw=0.8, ls="--", label=f"tau_CR = {tau_critical(THESIS):.3f} s")
    ax.axhline(4.0, color="gray", lw=0.8, ls=":", label="T = 4 s (no stabilising gain)")
    ax.plot([k_bar(THESIS)], [tau_critical(THESIS)], "r*", ms=10)
    ax.set_title("Fig. 5.7: theta = (0.02, 0.13, 0.1, 0.2)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "fig5_7.png"), dpi=120)
    plt.close(fig)


def main(outdir: str = "results/ch5_table5_2", quick: bool = False) -> pd.DataFrame:
    """Compute Table 5.2 and the curves, save PNG and Parquet; return the table."""
    os.makedirs(outdir, exist_ok=True)
    tab = table_5_2()
    tab.to_parquet(os.path.join(outdir, "table5_2.parquet"))
    cur = pd.concat([curves(p, name) for name, p in {"thesis": THESIS, **EXAMPLES}.items()], ignore_index=True)
    cur.to_parquet(os.path.join(outdir, "curves.parquet"))
    plot_all(outdir, tab)
    return tab


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/ch5_table5_2").parse_args()
    with pd.option_context("display.width", 200, "display.max_columns", 20, "display.max_colwidth", 60):
        print(main(a.outdir, a.quick))
