"""The ch. 3-5 reproductions: files written and the thesis's claims hold.

Quick mode by default; the full reproductions run with ``-m slow``."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest


QUICK = pytest.mark.parametrize("quick", [True, pytest.param(False, marks=pytest.mark.slow)])


def _files(tmp_path, names):
    for n in names:
        f = tmp_path / n
        assert f.exists() and f.stat().st_size > 0, n


@QUICK
def test_ch3_fig3_8(tmp_path, quick):
    from experiments import ch3_fig3_8 as ex
    summary = ex.main(outdir=str(tmp_path), quick=quick)
    _files(tmp_path, ["fig3_8.png", "samples.parquet", "summary.parquet"])
    s = summary.set_index(["case", "strategy"])
    # mu_hat* < 1/2 for r = 0.08 and > 1/2 for r = 0.5 (Sec. 3.5)
    assert s.loc[("small", "offline"), "mu_hat"] < 0.5 < s.loc[("large", "offline"), "mu_hat"]
    n = s.samples_to_tol
    assert (n >= 0).all()
    assert n[("small", "online")] <= n[("small", "offline")]
    assert n[("large", "online")] < n[("large", "offline")]
    # Proposition 3.4.5: offline contraction never exceeds rho(mu_hat)
    for case in ("small", "large"):
        assert s.loc[(case, "offline"), "max_contraction"] <= s.loc[(case, "offline"), "rho"]
    samples = pd.read_parquet(tmp_path / "samples.parquet")
    on = samples[(samples.case == "large") & (samples.strategy == "online")]
    err = on.err.values
    # Proposition 3.4.6: quadratic convergence near the reference, k_h -> 1/T
    near = err[:-1] < 0.05
    assert np.all(err[1:][near] <= 10.0 * err[:-1][near] ** 2)
    assert on.k.values[-2] == pytest.approx(1 / ex.T, rel=1e-3)


@QUICK
def test_ch4_fig4_8_9(tmp_path, quick):
    from experiments import ch4_fig4_8_9 as ex
    summary = ex.main(outdir=str(tmp_path), quick=quick)
    _files(tmp_path, ["fig4_8.png", "fig4_9.png", "samples.parquet", "summary.parquet"])
    assert len(summary) == 8
    assert (summary.samples_to_tol > 0).all()                       # both strategies, both norms converge
    assert (summary.max_contraction <= summary.rho).all()            # never above the computed rho
    far = summary[summary.initial == "q2"].set_index(["norm", "strategy"]).samples_to_tol
    for p in ("2", "inf"):
        assert far[(p, "online")] < far[(p, "offline")]


@QUICK
def test_ch4_fig4_10(tmp_path, quick):
    from experiments import ch4_fig4_10 as ex
    summary = ex.main(outdir=str(tmp_path), quick=quick)
    _files(tmp_path, ["fig4_10.png", "samples.parquet", "summary.parquet"])
    s = summary.set_index(["alpha", "strategy"])
    for strategy in ("offline", "online"):
        # Theorem 4.4.1: large alpha behaves like the kinematic model (contraction <= rho)
        assert s.loc[(30.0, strategy), "max_contraction"] <= s.loc[(30.0, strategy), "rho"]
        # small alpha: the error grows over some periods and has not converged
        assert s.loc[(0.3, strategy), "max_contraction"] > 1.0
        assert s.loc[(0.3, strategy), "final_err"] > 100 * s.loc[(30.0, strategy), "final_err"]
    assert s.loc[(30.0, "online"), "final_err"] < 1e-6
    assert (summary.min_tension > 0).all()  # cables stay taut


def test_ch5_table5_2(tmp_path):
    from experiments import ch5_table5_2 as ex
    tab = ex.main(outdir=str(tmp_path), quick=True)
    _files(tmp_path, ["table5_2.parquet", "curves.parquet", "fig5_3.png", "fig5_4.png", "fig5_5.png", "fig5_7.png"])
    t = tab.set_index("T")
    assert t.loc[0.5, "k_o"] == pytest.approx(2.0) and t.loc[1.5, "k_o"] == pytest.approx(2 / 3)
    assert t.loc[0.75, "k_o"] == pytest.approx(4 / 3)          # thesis prints 1.28 (see module docstring)
    assert not t.loc[4.0, "stable"] and math.isnan(t.loc[4.0, "k_o"])
    assert t.tau_CR.iloc[0] == pytest.approx(1.7120559678, abs=1e-9)
    assert t.loc[[0.5, 0.75, 1.5], "thesis_k_in_stability_set"].all()


@QUICK
def test_ch5_fig5_8_9(tmp_path, quick):
    from experiments import ch5_fig5_8_9 as ex
    summary = ex.main(outdir=str(tmp_path), quick=quick)
    _files(tmp_path, ["fig5_8.png", "fig5_9a.png", "dense.parquet", "samples.parquet", "theta.parquet"])
    s = summary[summary["T"] == 1.5].set_index("strategy")
    assert summary.feasible.all()
    # feed-forward at the reference (1, 2): asymptotic zero tracking error; (3) residual; (4) lag
    assert s.final_err[1] < 1e-9 and s.final_err[2] < 1e-9
    assert s.final_err[3] > 1e-4 and s.final_err[4] > 10 * s.final_err[3]
    theta = pd.read_parquet(tmp_path / "theta.parquet")
    assert (theta[["mu", "alpha", "gamma1", "gamma2"]].values >= 0).all() and theta.tau_CR.iloc[0] > 1.5
