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
  contraction out.  The curve ``T_c(k)`` itself cannot be drawn from closed forms:
  Prop. 5.3.5 only proves it exists (for ``k > k_2 = delta v_max``, with delta a
  Lipschitz-type constant of the Jacobian the thesis does not compute); the figure hatches
  the band it must lie in, ``tau_s(k) <= T_c(k) <= 2/k``.
* Figs. B.3-B.10 (``figB_3_10.png``, ``appendix_b.parquet``): the polynomials of the
  proofs of Props. 5.4.2-5.4.4 drawn from their printed expressions, each with the root
  the implemented closed form gives (``tau_s``, ``k_bar``, ``k_barbar``, ``tau_CR``),
  where the curve is 0 (or z = 1) to rounding.  B.9's root as the thesis prints it,
  ``(-(gamma1 + alpha mu) +- sqrt(...))/(...)``, does not solve its own polynomial
  (whose linear coefficient is ``2 (gamma1 + 2 alpha mu)``); the root drawn is the
  polynomial's, which is where the implemented ``rho_o(tau)`` reaches 1 (``tau_CR``).

Run ``python -m netcosim.experiments.ch5_table5_2``.  Writes ``table5_2.parquet``,
``curves.parquet``, ``appendix_b.parquet`` and ``fig5_3.png``, ``fig5_4.png``,
``fig5_5.png``, ``fig5_7.png``, ``figB_3_10.png``.
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
    k_barbar,
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
    lo = np.array([tau_s(k, THESIS) for k in K])
    ax.fill_between(K, lo, np.minimum(2 / K, 10), where=K > THESIS.alpha, hatch="//", facecolor="none",
                    edgecolor="gray", lw=0, label="T_c(k) lies here: above tau_s(k), below 2/k")
    ax.set_title("Fig. 5.3: stability set z < 1 (green) under-estimates T < T_c(k)\n"
                 "(T_c(k) of Prop. 5.3.5 has no closed form: only its bounds are drawn)", fontsize=9)
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


# ---------------------------------------------------------------- appendix B.4
#: Figs. B.3-B.10: figure -> (what it plots, x name).  Each curve is the thesis's printed
#: expression; its marked root is the implemented closed form of :mod:`sikm` it defines.
APPENDIX_B = {
    "B.3": ("z^-(k, tau) = 1 + tau (alpha - k) + tau^2 Q(k), k tau < 1; root of z^- = 1: tau_s1(k)", "tau"),
    "B.4": ("p_s2^-(k) = k^2 (1 - mu) - k (alpha + gamma1) - gamma2; root: k_bar", "k"),
    "B.5": ("p_s^=(k) = k^2 (mu - 1) + k (alpha + gamma1) + gamma2; root: k_bar", "k"),
    "B.6": ("z^+(k, tau) = -1 + tau (alpha + k) + tau^2 Q(k), k tau > 1; root of z^+ = 1: tau_s2(k)", "tau"),
    "B.7": ("p_tau_s+(k) = k^2 (mu - 1) + k (alpha + gamma1) + gamma2; root: k_bar", "k"),
    "B.8": ("p_v^-(k) = k^2 (1 - 2 mu) - k (alpha + 2 gamma1) - 2 gamma2; root: k_barbar", "k"),
    "B.9": ("p_v^-(tau) = (4 gamma2 mu - gamma1^2) tau^2 + 2 (gamma1 + 2 alpha mu) tau - 1; "
            "root: where rho_o(tau) = 1, i.e. tau_CR", "tau"),
    "B.10": ("p^=(tau) = gamma2 tau^2 + (alpha + gamma1) tau + mu - 1; root: 1/k_bar = tau_CR", "tau"),
}


def appendix_b(p: SIKMParams = THESIS, k_low: float = 0.4, k_high: float = 2.0, n: int = 300) -> pd.DataFrame:
    """The curves of Figs. B.3-B.10 for *p* (default the thesis's theta; B.9 with the
    ``1/2 < mu < 1`` example, where its branch of rho_o(tau) applies), each with the
    root the implemented closed form gives (``root``) and the curve's value there
    (``at_root``: 0 for a polynomial, 1 for z).  B.3 at ``k = k_low`` (1/s, between alpha
    and k_bar: tau_s = tau_s1), B.6 at ``k = k_high`` (above k_bar: tau_s = tau_s2).
    Columns: ``figure, x_name, x, y, root, at_root``."""
    a, g1, g2 = p.alpha, p.gamma1, p.gamma2
    mu = p.mu
    kb, kbb = k_bar(p), k_barbar(p)
    pv = EXAMPLES["1/2<mu<1"]

    def pv_tau(t, q=pv):
        return (4 * q.gamma2 * q.mu - q.gamma1 ** 2) * t * t + 2 * (q.gamma1 + 2 * q.alpha * q.mu) * t - 1

    curves_ = {
        "B.3": (lambda t: 1 + t * (a - k_low) + t * t * p.Q(k_low), tau_s(k_low, p), (0.0, 1.0 / k_low)),
        "B.4": (lambda k: k * k * (1 - mu) - k * (a + g1) - g2, kb, (0.0, 2 * kb)),
        "B.5": (lambda k: k * k * (mu - 1) + k * (a + g1) + g2, kb, (0.0, 2 * kb)),
        "B.6": (lambda t: -1 + t * (a + k_high) + t * t * p.Q(k_high), tau_s(k_high, p), (1.0 / k_high, 2.0 / k_high)),
        "B.7": (lambda k: k * k * (mu - 1) + k * (a + g1) + g2, kb, (0.0, 2 * kb)),
        "B.8": (lambda k: k * k * (1 - 2 * mu) - k * (a + 2 * g1) - 2 * g2, kbb, (0.0, 2 * kbb)),
        "B.9": (pv_tau, tau_critical(pv), (0.0, 2 * tau_critical(pv))),
        "B.10": (lambda t: g2 * t * t + (a + g1) * t + mu - 1, 1.0 / kb, (0.0, 2.0 / kb)),
    }
    out = []
    for fig, (f, root, (x0, x1)) in curves_.items():
        x = np.linspace(x0, x1, n)
        out.append(pd.DataFrame(dict(figure=fig, x_name=APPENDIX_B[fig][1], x=x, y=f(x), root=root,
                                     at_root=float(f(root)) if math.isfinite(root) else math.nan)))
    return pd.concat(out, ignore_index=True)


def plot_appendix_b(outdir: str, curves_: pd.DataFrame) -> None:
    """Figs. B.3-B.10 (``figB_3_10.png``): each curve and its implemented root (dotted)."""
    fig, axes = plt.subplots(2, 4, figsize=(16, 7))
    for ax, (name, g) in zip(axes.ravel(), curves_.groupby("figure", sort=False)):
        ax.plot(g.x, g.y)
        ax.axhline(1.0 if name in ("B.3", "B.6") else 0.0, color="k", lw=0.6)
        ax.axvline(g.root.iloc[0], color="r", ls=":", label=f"root {g.root.iloc[0]:.4g}")
        text = APPENDIX_B[name][0]
        ax.set_title(f"Fig. {name}: {text.split(' = ')[0]}; {text.split('; ')[-1]}", fontsize=8)
        ax.set_xlabel(g.x_name.iloc[0])
        ax.legend(fontsize=7)
    fig.suptitle("Appendix B.4, drawn from the closed forms (theta of Sec. 5.5, B.3 at k = 0.4, B.6 at k = 2; "
                 "B.9: mu = 0.7)")
    fig.tight_layout()
    fig.savefig(os.path.join(outdir, "figB_3_10.png"), dpi=110)
    plt.close(fig)


def main(outdir: str = "results/ch5_table5_2", quick: bool = False) -> pd.DataFrame:
    """Compute Table 5.2 and the curves, save PNG and Parquet; return the table."""
    os.makedirs(outdir, exist_ok=True)
    tab = table_5_2()
    tab.to_parquet(os.path.join(outdir, "table5_2.parquet"))
    cur = pd.concat([curves(p, name) for name, p in {"thesis": THESIS, **EXAMPLES}.items()], ignore_index=True)
    cur.to_parquet(os.path.join(outdir, "curves.parquet"))
    plot_all(outdir, tab)
    b = appendix_b()
    b.to_parquet(os.path.join(outdir, "appendix_b.parquet"))
    plot_appendix_b(outdir, b)
    return tab


if __name__ == "__main__":
    from netcosim.experiments._cli import experiment_parser
    a = experiment_parser(__doc__, "results/ch5_table5_2").parse_args()
    with pd.option_context("display.width", 200, "display.max_columns", 20, "display.max_colwidth", 60):
        print(main(a.outdir, a.quick))
