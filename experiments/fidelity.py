"""The thesis-fidelity table: every reproduced figure/table, the thesis's number, ours.

``python -m netcosim.experiments.fidelity --measure`` reads the Parquet tables the experiments
wrote under ``--outdir`` (default ``results/``, as for ``netcosim.experiments.main``; one
folder per experiment, named after its module as ``python -m netcosim.experiments.main``
writes them, or its default output directory: ``ch2/`` for ``ch2_landing``),
reduces them to the numbers the table quotes, stores those in
``experiments/data/fidelity_reproduced.json`` and rewrites the table in
``docs/fidelity.md`` (between its markers).  Without ``--measure`` the table is
rewritten from the stored numbers; ``--check`` exits with status 1 when
``docs/fidelity.md`` is not what the stored numbers give.

The numbers come from the full runs (no ``--quick``): regenerate after running the
experiments whose outputs changed.  Each row's verdict is computed from the numbers:
``reproduced`` (or ``simulated analogue`` for a simulated stand-in of a rig measurement)
when the thesis's statement holds for them, otherwise ``justified departure`` with the
document that measures why, or ``not reproduced`` when no document explains it; the
counts per verdict head the table.
"""

from __future__ import annotations

import argparse
import json
import math
import string
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parent.parent
#: The stored reproduced numbers (written by ``--measure``).
REPRODUCED = Path(__file__).with_name("data") / "fidelity_reproduced.json"
#: The document holding the table.
DOC = ROOT / "docs" / "fidelity.md"
BEGIN, END = "<!-- fidelity table: begin (python -m netcosim.experiments.fidelity) -->", "<!-- fidelity table: end -->"

#: Experiment modules whose default output directory is not ``results/<module>``.
DEFAULT_OUTDIRS = {"ch2_landing": "ch2"}


# ---------------------------------------------------------------- measuring outputs
def _ch2(d: Path) -> dict[str, float]:
    m = pd.read_parquet(d / "metrics.parquet").set_index("run")
    s = pd.read_parquet(d / "signals.parquet", columns=["run", "f_R", "dphi", "dtheta"])
    out = {}
    for run in ("ideal_nmpc_calm", "ideal_2lc_calm", "ideal_nmpc_wind", "ideal_2lc_wind"):
        key = run.removeprefix("ideal_")
        out[f"{key}.t_settle"] = float(m.loc[run, "t_settle"])
        out[f"{key}.d_PG_min_mm"] = 1e3 * float(m.loc[run, "d_PG_min"])
        out[f"{key}.f_L_max"] = float(m.loc[run, "f_L_max"])
        r = s[s["run"] == run]
        out[f"{key}.f_R_mean"] = float(r["f_R"].mean())
        out[f"{key}.dphi_max_deg"] = math.degrees(float(r["dphi"].abs().max()))
        out[f"{key}.dtheta_max_deg"] = math.degrees(float(r["dtheta"].abs().max()))
    out["wind.deviation_ratio"] = float(m.loc["ideal_2lc_wind", "wind_deviation_ratio"])
    if "ideal_2lcformer_wind" in m.index:
        out["wind.former_deviation_ratio"] = float(m.loc["ideal_2lcformer_wind", "wind_deviation_ratio"])
    sweep = pd.read_parquet(d / "delay_sweep.parquet")
    plan = sweep[(sweep["scheme"] == "plan") & (sweep["delay"] == 0.0) & sweep["wind"]]
    if len(plan) and "wind_ratio" in sweep:
        out["wind.plan_deviation_ratio"] = float(plan["wind_ratio"].iloc[0])
    band = d / "solve_time_band.parquet"
    if band.exists():  # the recorded solve times replayed from several offsets
        b = pd.read_parquet(band)
        for scheme, g in b.groupby("scheme"):
            out[f"recorded.{scheme}.d_PG_min_mm"] = 1e3 * float(g["d_PG_min"].min())
            out[f"recorded.{scheme}.f_L_max"] = float(g["f_L_max"].max())
            out[f"recorded.{scheme}.n_failed"] = float((g["failed"] != "").sum())
            out[f"recorded.{scheme}.n"] = float(len(g))
    cable = d / "cable_sweep.parquet"
    if cable.exists():  # peak f_L over m_B, l (thesis scheme): the parameters that give "<= 6 N"
        c = pd.read_parquet(cable).set_index(["m_B", "l", "wind"])
        for wind, key in (("calm", "calm"), ("3/1 N", "wind"), ("1/0.3 N", "light_wind")):
            out[f"cable.0.5_0.5.{key}.f_L_max"] = float(c.loc[(0.5, 0.5, wind), "f_L_max"])
            out[f"cable.min.{key}.f_L_max"] = float(c.xs(wind, level="wind")["f_L_max"].min())
        out["cable.wind_radial_max"] = float(c["wind_radial_max"].max())
    return out


def _nmpc_times(d: Path) -> dict:
    t = pd.read_parquet(d / "rti_times.parquet")
    out: dict = {"host": str(t["host"].iloc[0])}
    for col in ("total", "feedback"):
        a = pd.Series(1e3 * t[col].to_numpy())
        out[f"{col}.median_ms"] = float(a.median())
        out[f"{col}.p99_ms"] = float(a.quantile(0.99))
        out[f"{col}.max_ms"] = float(a.max())
    if "repeat" in t:
        per = 1e3 * t.groupby("repeat")["total"].max()
        out["repeats"] = float(len(per))
        out["repeats_over_5ms"] = float((per >= 5.0).sum())
    return out


def _ch3(d: Path) -> dict[str, float]:
    s = pd.read_parquet(d / "summary.parquet").set_index(["case", "strategy"])
    out = {}
    for case in ("small", "large"):
        out[f"{case}.mu_hat"] = float(s.loc[(case, "offline"), "mu_hat"])
        for strat in ("offline", "online"):
            out[f"{case}.{strat}.samples"] = float(s.loc[(case, strat), "samples_to_tol"])
    return out


def _ch3_rig(d: Path) -> dict[str, float]:
    s = pd.read_parquet(d / "summary.parquet").set_index(["strategy", "waypoint"])
    h = pd.read_parquet(d / "samples.parquet", columns=["strategy", "h", "tau_o"])
    off, on = s.loc["offline"], s.loc["online"]
    tau_on = h[h["strategy"] == "online"].groupby("h")["tau_o"].first()
    return {"offline.err_end_max": float(off["err_end"].max()), "online.err_end_max": float(on["err_end"].max()),
            "err_ratio_min": float((off["err_end"] / on["err_end"]).min()),
            "speed_ratio_min": float((on["max_speed"] / off["max_speed"]).min()),
            "online.tau_o_last": float(tau_on.iloc[-1]), "online.tau_o_min": float(tau_on.min()),
            "offline.tau_o": float(h.loc[h["strategy"] == "offline", "tau_o"].iloc[0])}


def _ch4_8_9(d: Path) -> dict[str, float]:
    s = pd.read_parquet(d / "summary.parquet").set_index(["norm", "initial", "strategy"])
    return {f"{n}.{q}.{st}.samples": float(s.loc[(n, q, st), "samples_to_tol"])
            for n in ("2", "inf") for q in ("q1", "q2") for st in ("offline", "online")}


def _ch4_10(d: Path) -> dict[str, float]:
    s = pd.read_parquet(d / "summary.parquet")
    out = {"rho": float(s["rho"].iloc[0])}
    for a, g in s.groupby("alpha"):
        out[f"alpha{a:g}.max_contraction"] = float(g["max_contraction"].max())
        out[f"alpha{a:g}.final_err"] = float(g["final_err"].max())
    return out


def _flycrane_network(d: Path) -> dict[str, float]:
    s = pd.read_parquet(d / "summary.parquet").set_index(["strategy", "loss"])
    out = {}
    for st in ("offline", "online"):
        for loss in (0.0, 0.2, 0.3, 0.7):
            if (st, loss) in s.index:
                out[f"{st}.{loss:g}.iae"] = float(s.loc[(st, loss), "iae_median"])
                out[f"{st}.{loss:g}.t_settle"] = float(s.loc[(st, loss), "t_settle_median"])
                out[f"{st}.{loss:g}.t_settle_q10"] = float(s.loc[(st, loss), "t_settle_q10"])
                out[f"{st}.{loss:g}.t_settle_q90"] = float(s.loc[(st, loss), "t_settle_q90"])
                out[f"{st}.{loss:g}.runs"] = float(s.loc[(st, loss), "runs"])
    if (d / "loss_steps.parquet").exists():      # the verdict of each loss step of Fig. 4.11
        for r in pd.read_parquet(d / "loss_steps.parquet").itertuples():
            key = f"{r.strategy}.step{r.loss_from:g}_{r.loss_to:g}"
            for col in ("iae_median_from", "iae_median_to", "diff", "ci_lo", "ci_hi", "runs_from", "runs_to",
                        "final_e_median_from", "final_e_median_to", "cheaper_fraction", "level"):
                out[f"{key}.{col}"] = float(getattr(r, col))
    return out


def _table5_2(d: Path) -> dict[str, float]:
    t = pd.read_parquet(d / "table5_2.parquet").set_index("T")
    out = {"tau_CR": float(t["tau_CR"].iloc[0])}
    for T, row in t.iterrows():
        out[f"T{T:g}.k_o"] = float(row["k_o"])
        out[f"T{T:g}.rho_o"] = float(row["rho_o"])
        out[f"T{T:g}.stable"] = float(bool(row["stable"]))
        if "z_at_thesis_k" in row and math.isfinite(row["z_at_thesis_k"]):
            out[f"T{T:g}.z_thesis_k"] = float(row["z_at_thesis_k"])
    return out


#: theta.parquet source -> key prefix of its numbers.
THETA_SOURCES = {"environment, true errors": "theta", "environment, MoCap errors": "theta_mocap",
                 "environment, true errors, 10 s reference": "theta_fast"}


def _ch5_8_9(d: Path) -> dict[str, float]:
    s = pd.read_parquet(d / "summary.parquet")
    th = pd.read_parquet(d / "theta.parquet").set_index("source")
    nz = pd.read_parquet(d / "noise.parquet", columns=["sigma", "t", "err"])
    out = {}
    if "k_rule" not in s:      # tables written before the printed-k variant
        s = s.assign(k_rule="", run=s["feasible"])
    s = s.assign(line=[f"s{st}" + ("p" if r == "printed" else "") for st, r in zip(s["strategy"], s["k_rule"])])
    ran = s[s["run"]]
    for r in ran.itertuples():
        out[f"T{r.T:g}.{r.line}.mean_err"] = float(r.mean_err)
        out[f"T{r.T:g}.{r.line}.early_err"] = float(r.early_err)
        if "err_one_period" in s:
            out[f"T{r.T:g}.{r.line}.err_one_period"] = float(r.err_one_period)
    for source, prefix in THETA_SOURCES.items():
        if source in th.index:
            for k in ("mu", "alpha", "gamma1", "gamma2", "tau_CR"):
                out[f"{prefix}.{k}"] = float(th.loc[source, k])
                for b in ("lo", "hi"):
                    if f"{k}_{b}" in th:
                        out[f"{prefix}.{k}_{b}"] = float(th.loc[source, f"{k}_{b}"])
    if (s["T"] == 4.0).any():
        out["T4.s2.run"] = float(ran[(ran["T"] == 4.0) & (ran["line"] == "s2")].shape[0] > 0)
        out["T4.s4.run"] = float(ran[(ran["T"] == 4.0) & (ran["line"] == "s4")].shape[0] > 0)
    # Fig. 5.9b: every line averaged over the same periods (those at which every line ran)
    common = set.intersection(*(set(g["T"]) for _, g in ran.groupby("line")))
    if {0.5, 0.75, 1.5} <= common:
        for line, g in ran[ran["T"].isin(common)].groupby("line"):
            out[f"{line}.mean_over_T"] = float(g["mean_err"].mean())
            out[f"{line}.early_over_T"] = float(g["early_err"].mean())
    for sigma, g in nz[nz["t"] > 5.0].groupby("sigma"):
        out[f"noise{sigma:g}.mean_err"] = float(g["err"].mean())
    return out


#: Experiment module -> function reading its output directory into named numbers.
MEASURES: dict[str, Callable[[Path], dict]] = {
    "ch2_landing": _ch2, "nmpc_benchmark": _nmpc_times, "ch3_fig3_8": _ch3, "ch3_fig3_10_12": _ch3_rig,
    "ch4_fig4_8_9": _ch4_8_9,
    "ch4_fig4_10": _ch4_10, "flycrane_network": _flycrane_network, "ch5_table5_2": _table5_2, "ch5_fig5_8_9": _ch5_8_9}


def measure(results: str | Path, experiments: list[str] | None = None) -> dict:
    """The named numbers of every experiment (default: all of :data:`MEASURES`) whose
    output directory exists under *results*: ``<results>/<module>`` as ``python -m
    netcosim.experiments.main`` writes it, else the experiment's default (``<results>/ch2`` for
    ``ch2_landing``).  A missing directory is skipped; one without the expected tables
    raises ``FileNotFoundError``.  Keys are ``"<experiment>.<quantity>"``; angles in degrees, distances in mm
    where the key says ``_mm``, forces in N, times in s."""
    out: dict = {}
    for name in experiments or list(MEASURES):
        d = Path(results) / name
        if not d.is_dir():
            d = Path(results) / DEFAULT_OUTDIRS.get(name, name)
        if d.is_dir():
            out.update({f"{name}.{k}": v for k, v in MEASURES[name](d).items()})
    return out


# ---------------------------------------------------------------- the table
#: The verdicts a row can carry, in the order the header counts them.
VERDICTS = ("reproduced", "justified departure", "simulated analogue", "not reproduced")


@dataclass(frozen=True)
class Claim:
    """One row: what the thesis states at *figure* (section *source*), the experiment
    reproducing it, the thesis's number (*thesis*), ours (*reproduced*: a format string
    over the measured numbers, keys without the experiment prefix), and *holds*, the
    thesis's statement as a test on those numbers.  *explained* names the document that
    measures why the statement does not hold, if it does not.

    The verdict is computed: when *holds* is true, *kind* (``"reproduced"``, or
    ``"simulated analogue"`` for a row whose experiment stands in for a measurement the
    thesis made on hardware); when it is false, ``"justified departure"`` if *explained*
    names a document, else ``"not reproduced"``.  *reason* (a format string like
    *reproduced*) states the evidence: the interval, the number of seeds, or why the row
    is deterministic."""

    figure: str
    source: str
    experiment: str
    thesis: str
    reproduced: str
    holds: Callable[[dict[str, float]], bool]
    explained: str = ""
    kind: str = "reproduced"
    reason: str = ""

    def __post_init__(self):
        if self.kind not in ("reproduced", "simulated analogue"):
            from netcosim.errors import ConfigurationError
            raise ConfigurationError(f"Claim kind {self.kind!r} of {self.figure}: a row that holds is "
                                     "'reproduced' or a 'simulated analogue'")


def _v(values: dict[str, float], experiment: str) -> dict[str, float]:
    p = experiment + "."
    return {k[len(p):]: v for k, v in values.items() if k.startswith(p)}


#: why the Figs. 3.10-3.12 rows are a simulated analogue
RIG_STAND_IN = ("the thesis measured this on the LAAS rig; here the dynamic model over simulated 802.11b with an "
                "assumed 10 % loss stands in for it (deterministic: one run)")

CLAIMS: list[Claim] = [
    Claim("Fig. 2.8", "§2.6.2", "ch2_landing", "landing \"in almost 0.7 seconds\" (max rates > 100°/s)",
          "settled within 1°: NMPC {nmpc_calm.t_settle:.3f} s, 2LC {2lc_calm.t_settle:.3f} s; "
          "NMPC max |φ̇| {nmpc_calm.dphi_max_deg:.0f}°/s, |ϑ̇| {nmpc_calm.dtheta_max_deg:.0f}°/s",
          lambda v: abs(v["nmpc_calm.t_settle"] - 0.7) < 0.1 and v["2lc_calm.t_settle"] < 0.8
          and max(v["nmpc_calm.dphi_max_deg"], v["nmpc_calm.dtheta_max_deg"]) > 100),
    Claim("Fig. 2.9", "§2.6.2", "ch2_landing", "2LC requires smaller inputs, smaller thrust at the end",
          "mean thrust 2LC {2lc_calm.f_R_mean:.2f} N, NMPC {nmpc_calm.f_R_mean:.2f} N",
          lambda v: v["2lc_calm.f_R_mean"] < v["nmpc_calm.f_R_mean"]),
    Claim("Fig. 2.10", "§2.6.2", "ch2_landing", "d_PG > 0 (2.7) always; 2LC closer to the ground",
          "min d_PG: NMPC {nmpc_calm.d_PG_min_mm:.1f} mm, 2LC {2lc_calm.d_PG_min_mm:.1f} mm",
          lambda v: 0 < v["2lc_calm.d_PG_min_mm"] < v["nmpc_calm.d_PG_min_mm"]),
    Claim("Fig. 2.10 (text)", "§2.6.2", "ch2_landing",
          "0 ≤ f_L ≤ f_L,max, \"always far from the limits\" (≤ 6 N read as far)",
          "peak f_L {2lc_calm.f_L_max:.2f} N (2LC), {nmpc_calm.f_L_max:.2f} N (NMPC) with m_B = 1 kg, l = 1 m; "
          "m_B = l = 0.5: {cable.0.5_0.5.calm.f_L_max:.2f} N",
          lambda v: max(v["2lc_calm.f_L_max"], v["nmpc_calm.f_L_max"]) <= 6.0,
          "m_B, l are not in the thesis; m_B = l = 0.5 gives ≤ 6 N (docs/nmpc.md, \"Cable stress\")"),
    Claim("Fig. 2.11", "§2.6.2", "ch2_landing", "2LC rejects the wind better than NMPC alone (\"significantly\")",
          "wind-induced deviation 2LC / NMPC: thesis scheme {wind.deviation_ratio:.2f}; variants: former default "
          "{wind.former_deviation_ratio:.3f}, (f_R, τ_R) from the plan {wind.plan_deviation_ratio:.2f}",
          lambda v: v["wind.deviation_ratio"] < 1.0),
    Claim("Fig. 2.12", "§2.6.2", "ch2_landing", "under wind NMPC's thrust slightly greater than 2LC's",
          "mean thrust NMPC {nmpc_wind.f_R_mean:.2f} N, 2LC {2lc_wind.f_R_mean:.2f} N (the 2LC presses on its "
          "landers at the end: docs/nmpc.md, \"Thrust at touchdown\")",
          lambda v: v["nmpc_wind.f_R_mean"] > v["2lc_wind.f_R_mean"]),
    Claim("Fig. 2.13", "§2.6.2", "ch2_landing", "(2.8) satisfied under wind; ‖f_L‖ ≤ 6 N",
          "min d_PG {2lc_wind.d_PG_min_mm:.1f} mm; peak f_L {2lc_wind.f_L_max:.2f} N (m_B = 1 kg, l = 1 m); "
          "m_B = l = 0.5: {cable.0.5_0.5.wind.f_L_max:.2f} N (3 N / 1 N wind), "
          "{cable.0.5_0.5.light_wind.f_L_max:.2f} N (1 N / 0.3 N); wind radial term ≤ {cable.wind_radial_max:.2f} N",
          lambda v: v["2lc_wind.d_PG_min_mm"] > 0 and v["2lc_wind.f_L_max"] <= 6.0,
          "m_B, l and the wind's amplitudes are not in the thesis; m_B = 0.5 kg, l ≤ 1 m give ≤ 6 N under "
          "the project's wind (docs/nmpc.md, \"Cable stress\")"),
    Claim("§2.6.2 (real time)", "§2.4, §2.6.2", "ch2_landing",
          "the 2LC works with the NMPC computed on line (solve < 5 ms per 10 ms sample)",
          "recorded solve times replayed from {recorded.thesis.n:.0f} offsets: "
          "min d_PG {recorded.thesis.d_PG_min_mm:.2f} mm, peak f_L {recorded.thesis.f_L_max:.2f} N "
          "(poles -120 rad/s); former default (plan, -60 rad/s): "
          "min d_PG {recorded.former_default.d_PG_min_mm:.0f} mm, peak f_L {recorded.former_default.f_L_max:.1f} N, "
          "{recorded.former_default.n_failed:.0f} singular",
          lambda v: v["recorded.thesis.d_PG_min_mm"] >= 0 and v["recorded.thesis.f_L_max"] <= 10.0
          and v["recorded.thesis.n_failed"] == 0,
          kind="simulated analogue",
          reason="the solve times are this project's Python/CasADi RTI, recorded once and replayed"),
    Claim("§2.6.2 (NMPC time)", "§2.6.2", "nmpc_benchmark", "maximal NMPC time per sampling instant < 5 ms",
          "RTI per sample (python -m benchmarks.nmpc --rti-only, {repeats:.0f} × 100 samples): median "
          "{total.median_ms:.2f} ms, p99 {total.p99_ms:.2f} ms, max {total.max_ms:.2f} ms "
          "({repeats_over_5ms:.0f} of {repeats:.0f} runs reach 5 ms); host: {host}",
          lambda v: v["total.max_ms"] < 5.0,
          "Python + CasADi + HPIPM on a shared host, not the thesis's compiled MATMPC C code; the median is "
          "what the host's load leaves (docs/nmpc.md, \"Measured costs\")"),
    Claim("Fig. 3.8", "§3.5", "ch3_fig3_8", "μ̂* < ½ for r₁ = 0.08, > ½ for r₂ = 0.5",
          "μ̂* = {small.mu_hat:.3f} / {large.mu_hat:.3f}",
          lambda v: v["small.mu_hat"] < 0.5 < v["large.mu_hat"]),
    Claim("Fig. 3.8", "§3.5", "ch3_fig3_8", "μ < ½: strategies \"quite the same\"; μ > ½: online much faster",
          "samples to 1e-6, offline / online: {small.offline.samples:.0f} / {small.online.samples:.0f} (small), "
          "{large.offline.samples:.0f} / {large.online.samples:.0f} (large)",
          lambda v: abs(v["small.offline.samples"] - v["small.online.samples"]) <= 1
          and v["large.offline.samples"] > 3 * v["large.online.samples"]),
    Claim("Fig. 3.10", "§3.6", "ch3_fig3_10_12", "rig, T = 1.5 s: online converges to the waypoints much faster",
          "largest ‖e‖ at a waypoint switch: offline {offline.err_end_max:.3f}, online {online.err_end_max:.4f} "
          "(online ≥ {err_ratio_min:.0f}× smaller at every switch; simulated, 10 % loss)",
          lambda v: v["err_ratio_min"] > 3.0,
          kind="simulated analogue",
          reason=RIG_STAND_IN),
    Claim("Fig. 3.11", "§3.6", "ch3_fig3_10_12", "online desired robot velocities larger than offline",
          "peak robot speed online / offline ≥ {speed_ratio_min:.2f} at every waypoint",
          lambda v: v["speed_ratio_min"] > 1.0,
          kind="simulated analogue",
          reason=RIG_STAND_IN),
    Claim("Fig. 3.12", "§3.6", "ch3_fig3_10_12", "τ₀ → 1 and k_h → 1/T as q → q^r",
          "online τ_o at the last sample {online.tau_o_last:.4f} (min {online.tau_o_min:.2f}); "
          "offline τ̄_o = {offline.tau_o:.3f}",
          lambda v: abs(v["online.tau_o_last"] - 1.0) < 0.01 and v["online.tau_o_min"] > v["offline.tau_o"],
          kind="simulated analogue",
          reason=RIG_STAND_IN),
    Claim("Fig. 4.8", "§4.6", "ch4_fig4_8_9", "2-norm: q₁ \"more or less the same\", q₂ difference evident",
          "samples to 1e-8, offline / online: q₁ {2.q1.offline.samples:.0f} / {2.q1.online.samples:.0f}, "
          "q₂ {2.q2.offline.samples:.0f} / {2.q2.online.samples:.0f}",
          lambda v: abs(v["2.q1.offline.samples"] - v["2.q1.online.samples"]) <= 1
          and v["2.q2.offline.samples"] > 3 * v["2.q2.online.samples"],
          reason="deterministic (kinematic model, no noise, no loss): one run is the result"),
    Claim("Fig. 4.9", "§4.6", "ch4_fig4_8_9", "∞-norm: a similar result",
          "samples to 1e-8, offline / online: q₁ {inf.q1.offline.samples:.0f} / {inf.q1.online.samples:.0f}, "
          "q₂ {inf.q2.offline.samples:.0f} / {inf.q2.online.samples:.0f}",
          lambda v: abs(v["inf.q1.offline.samples"] - v["inf.q1.online.samples"]) <= 1
          and v["inf.q2.offline.samples"] > 3 * v["inf.q2.online.samples"],
          reason="deterministic (kinematic model, no noise, no loss): one run is the result"),
    Claim("Fig. 4.10", "§4.6", "ch4_fig4_10", "large α converges (Thm 4.4.1); small α not guaranteed",
          "max per-sample contraction: α = 30 {alpha30.max_contraction:.2f}, "
          "α = 0.3 {alpha0.3.max_contraction:.2f} (ρ = {rho:.2f})",
          lambda v: v["alpha30.max_contraction"] < 1.0 < v["alpha0.3.max_contraction"],
          reason="deterministic (dynamic model, no noise, no loss): one run per α is the result"),
    Claim("Fig. 4.11 (0 → 30 %)", "§4.6.1", "flycrane_network", "performance worse as loss grows: 0 → 30 %",
          "median IAE offline {offline.step0_0.3.iae_median_from:.2f} → {offline.step0_0.3.iae_median_to:.2f}, "
          "difference {offline.step0_0.3.diff:+.2f} [{offline.step0_0.3.ci_lo:+.2f}, {offline.step0_0.3.ci_hi:+.2f}]; "
          "online {online.step0_0.3.iae_median_from:.2f} → {online.step0_0.3.iae_median_to:.2f}, "
          "{online.step0_0.3.diff:+.2f} [{online.step0_0.3.ci_lo:+.2f}, {online.step0_0.3.ci_hi:+.2f}]",
          lambda v: v["offline.step0_0.3.ci_lo"] > 0 and v["online.step0_0.3.ci_lo"] > 0,
          "docs/flycrane_network.md, Results",
          reason="95 % bootstrap interval of the median difference, {offline.step0_0.3.runs_from:.0f} runs at 0 % "
          "(deterministic) and {offline.step0_0.3.runs_to:.0f} seeds at 30 % per strategy; offline: "
          "{offline.step0_0.3.cheaper_fraction:.0%} of the 30 % runs cost less than the loss-free run and the "
          "median final ‖e‖ is lower at 30 % ({offline.step0_0.3.final_e_median_to:.1e} vs "
          "{offline.step0_0.3.final_e_median_from:.1e}): a held command of the small offline gain (kT = 0.32) "
          "keeps moving the load towards qʳ"),
    Claim("Fig. 4.11 (30 → 70 %)", "§4.6.1", "flycrane_network", "performance worse as loss grows: 30 → 70 %",
          "median IAE offline {offline.step0.3_0.7.iae_median_from:.2f} → {offline.step0.3_0.7.iae_median_to:.2f}, "
          "difference {offline.step0.3_0.7.diff:+.2f} [{offline.step0.3_0.7.ci_lo:+.2f}, "
          "{offline.step0.3_0.7.ci_hi:+.2f}]; online {online.step0.3_0.7.iae_median_from:.2f} → "
          "{online.step0.3_0.7.iae_median_to:.2f}, {online.step0.3_0.7.diff:+.2f} "
          "[{online.step0.3_0.7.ci_lo:+.2f}, {online.step0.3_0.7.ci_hi:+.2f}]",
          lambda v: v["offline.step0.3_0.7.ci_lo"] > 0 and v["online.step0.3_0.7.ci_lo"] > 0,
          "docs/flycrane_network.md, Results",
          reason="95 % bootstrap interval of the median difference, {offline.step0.3_0.7.runs_from:.0f} seeds "
          "per loss and strategy"),
    Claim("Figs. A.2–A.6", "app. A.1", "flycrane_network", "20 % loss: online converges faster (bigger gain)",
          "at 20 %: median settling {online.0.2.t_settle:.1f} s online, {offline.0.2.t_settle:.1f} s offline; "
          "IAE {online.0.2.iae:.2f} / {offline.0.2.iae:.2f}",
          lambda v: v["online.0.2.t_settle"] < v["offline.0.2.t_settle"],
          reason="{online.0.2.runs:.0f} seeds per strategy; 10–90 % settling band online "
          "[{online.0.2.t_settle_q10:.1f}, {online.0.2.t_settle_q90:.1f}] s, offline "
          "[{offline.0.2.t_settle_q10:.1f}, {offline.0.2.t_settle_q90:.1f}] s"),
    Claim("Table 5.2", "§5.5", "ch5_table5_2", "k_off = 2, 1.28, 0.67 at T = 0.5, 0.75, 1.5 s",
          "k_o = {T0.5.k_o:.3f}, {T0.75.k_o:.3f}, {T1.5.k_o:.3f} (Prop. 5.4.4)",
          lambda v: all(abs(v[f"T{T}.k_o"] - k) < 0.01 for T, k in (("0.5", 2.0), ("0.75", 1.28), ("1.5", 0.67))),
          "docs/controllers.md, Table 5.2",
          reason="closed form, exact: k_o = 1/T (μ < ½); the printed 1.28 is inside the stability set, "
          "z(1.28, 0.75) = {T0.75.z_thesis_k:.3f} against ρ_o = {T0.75.rho_o:.3f}: stabilising, not optimal"),
    Claim("Table 5.2", "§5.5", "ch5_table5_2", "T = 4 s: strategy 2 infeasible, T > τ_CR ≈ 1.71 s (θ of §5.5)",
          "τ_CR = {tau_CR:.3f} s; ρ_o(4 s) = {T4.rho_o:.2f}",
          lambda v: abs(v["tau_CR"] - 1.71) < 0.01 and v["T4.stable"] == 0.0,
          reason="closed form, exact (τ_CR = 1/k̄ for the thesis's θ)"),
    Claim("Fig. 5.7", "§5.5", "ch5_fig5_8_9", "θ̂ = (μ, α, γ₁, γ₂) = (0.02, 0.13, 0.1, 0.2)",
          "θ̂ = ({theta.mu:.3f}, {theta.alpha:.3f}, {theta.gamma1:.3f}, {theta.gamma2:.3f}), "
          "μ̂ ∈ [{theta.mu_lo:.3f}, {theta.mu_hi:.3f}], γ̂₂ ∈ [{theta.gamma2_lo:.3f}, {theta.gamma2_hi:.3f}], "
          "τ_CR = {theta.tau_CR:.2f} s ∈ [{theta.tau_CR_lo:.2f}, {theta.tau_CR_hi:.2f}]; 10 s reference: "
          "θ̂ = ({theta_fast.mu:.3f}, {theta_fast.alpha:.3f}, {theta_fast.gamma1:.3f}, {theta_fast.gamma2:.3f}), "
          "γ̂₂ ∈ [{theta_fast.gamma2_lo:.3f}, {theta_fast.gamma2_hi:.3f}], τ_CR = {theta_fast.tau_CR:.2f} s "
          "∈ [{theta_fast.tau_CR_lo:.2f}, {theta_fast.tau_CR_hi:.2f}]",
          lambda v: v["theta.mu_lo"] <= 0.02 <= v["theta.mu_hi"]
          and v["theta.gamma2_lo"] <= 0.2 <= v["theta.gamma2_hi"],
          "docs/controllers.md, Figs. 5.8/5.9 (different plant)",
          reason="95 % bootstrap intervals over resampled sample sets (500 resamples of the 432 one-period "
          "samples), lopsided about the fit, which is an envelope (a resample can only lose binding samples). "
          "The thesis's μ and γ₂ lie outside both intervals: μ̂ carries the robots' velocity-tracking lag "
          "(the audit's reading, not re-measured); the 3× faster reference raises γ̂₂ 1.7× and lowers τ_CR, "
          "but γ̂₂ stays 4× below 0.2, so the reference's speed explains only part of its gap"),
    Claim("Figs. 5.8/5.9a", "§5.5", "ch5_fig5_8_9", "T = 1.5 s: 4 lags; 1 and 2 slightly better than 3",
          "mean error 1 / 2 / 3 / 4: {T1.5.s1.mean_err:.2e} / {T1.5.s2.mean_err:.2e} / "
          "{T1.5.s3.mean_err:.2e} / {T1.5.s4.mean_err:.2e}",
          lambda v: max(v["T1.5.s1.mean_err"], v["T1.5.s2.mean_err"]) < v["T1.5.s3.mean_err"]
          < v["T1.5.s4.mean_err"],
          reason="one MoCap-noise seed (no seed band); the margins of 3 and 4 over 1 are the numbers shown, "
          "against a difference between 1 and 2 of the noise's size"),
    Claim("Fig. 5.9b", "§5.5", "ch5_fig5_8_9", "T = 4 s: strategy 2 not run (T > τ_CR); 4 dropped",
          "fitted τ_CR = {theta.tau_CR:.2f} s, 95 % interval [{theta.tau_CR_lo:.2f}, {theta.tau_CR_hi:.2f}] s; "
          "strategy 2 at T = 4 s run: {T4.s2.run:.0f}; strategy 4 at T = 4 s run: {T4.s4.run:.0f}",
          lambda v: 1.5 < v["theta.tau_CR_lo"] and v["theta.tau_CR_hi"] < 4.0 and v["T4.s2.run"] == 0.0
          and v["T4.s4.run"] == 0.0,
          reason="the whole τ_CR interval lies between 1.5 and 4 s, so the x of Table 5.2 holds for every "
          "resample; it holds by compensation: μ̂ too large and γ̂₂ too small (row Fig. 5.7)"),
    Claim("Fig. 5.9b", "§5.5", "ch5_fig5_8_9", "mean over T: 4 very much larger, 3 slower than 1 and 2",
          "mean over the same T = 0.5, 0.75, 1.5 s, 1 / 2 / 2 (printed k) / 3 / 4: {s1.mean_over_T:.2e} / "
          "{s2.mean_over_T:.2e} / {s2p.mean_over_T:.2e} / {s3.mean_over_T:.2e} / {s4.mean_over_T:.2e}",
          lambda v: max(v["s1.mean_over_T"], v["s2.mean_over_T"], v["s2p.mean_over_T"]) < v["s3.mean_over_T"]
          < v["s4.mean_over_T"],
          reason="every line averaged over the same periods (4 is not run at 4 s, 2 not beyond τ_CR); "
          "one MoCap-noise seed (no seed band)"),
    Claim("Fig. 5.9b", "§5.5", "ch5_fig5_8_9", "1 slightly better than 2 in the first seconds",
          "‖e‖ after one period at T = 0.75 s, 1 / 2 with k = 1.28 (printed) / 2 with k_o = 1/T: "
          "{T0.75.s1.err_one_period:.3e} / {T0.75.s2p.err_one_period:.3e} / {T0.75.s2.err_one_period:.3e}; "
          "mean over the first 6 s and T, 1 / 2 (1.28) / 2 (1/T): {s1.early_over_T:.4e} / {s2p.early_over_T:.4e} / "
          "{s2.early_over_T:.4e}",
          lambda v: v["T0.75.s1.err_one_period"] < v["T0.75.s2p.err_one_period"]
          and v["s1.early_over_T"] < v["s2p.early_over_T"],
          "docs/controllers.md, Figs. 5.8/5.9",
          reason="after one period 1 is better with the printed k (deterministic: the controller reads the known "
          "start, the MoCap noise enters after it); from the second sample on 2 with 1.28 is 1–6 % better and "
          "better on the 6 s mean (one noise seed): the thesis's edge of 1 lasts one period here.  With "
          "k_o = 1/T (Prop. 5.4.4) 1 and 2 coincide up to the noise"),
    Claim("Fig. 5.9 (noise)", "§5.5", "ch5_fig5_8_9", "σ₁ = 0.01 worse than σ₂ = 0.003, still bounded",
          "mean error after 5 s: {noise0.003.mean_err:.2e} (σ₂), {noise0.01.mean_err:.2e} (σ₁)",
          lambda v: v["noise0.003.mean_err"] < v["noise0.01.mean_err"] < 0.05,
          reason="one MoCap-noise seed per σ (no seed band), each a mean over 55 s"),
]


def _fmt(x) -> str:
    return str(x).replace("|", "\\|")


def rows(values: dict[str, float]) -> pd.DataFrame:
    """The table as a DataFrame: columns ``figure, source, experiment, thesis,
    reproduced, status, verdict, reason``; one row per :data:`CLAIMS` entry (``not run``
    where the experiment's numbers are absent).  ``status`` names the explaining document
    (``justified departure: <document>``); ``verdict`` is one of :data:`VERDICTS` (see :class:`Claim`)."""
    out = []
    fmt = _DottedKeys()
    for c in CLAIMS:
        v = _v(values, c.experiment)
        try:
            text = fmt.vformat(c.reproduced, (), v)
            reason = fmt.vformat(c.reason, (), v)
            ok = bool(c.holds(v))
        except KeyError:
            text, status, verdict, reason = "not run", "not run", "not run", ""
        else:
            status = "reproduced" if ok else (f"justified departure: {c.explained}" if c.explained
                                                else "NOT REPRODUCED")
            verdict = c.kind if ok else ("justified departure" if c.explained else "not reproduced")
        out.append(dict(figure=c.figure, source=c.source, experiment=c.experiment, thesis=c.thesis,
                        reproduced=text, status=status, verdict=verdict, reason=reason))
    return pd.DataFrame(out)


def verdict_counts(df: pd.DataFrame) -> str:
    """The header line: how many rows carry each verdict of :data:`VERDICTS` (and ``not
    run``, if any)."""
    counts = df["verdict"].value_counts()
    parts = [f"{int(counts.get(v, 0))} {v}" for v in VERDICTS]
    if counts.get("not run", 0):
        parts.append(f"{int(counts['not run'])} not run")
    return f"**Verdicts** ({len(df)} rows): " + ", ".join(parts) + "."


class _DottedKeys(string.Formatter):
    """Formatting whose field names are whole keys, dots included (``{T0.5.k_o:.3f}``)."""

    def get_field(self, field_name, args, kwargs):
        return kwargs[field_name], field_name


def render(values: dict[str, float]) -> str:
    """The verdict counts and the Markdown table (thesis figure/table → experiment → the
    thesis's number → ours → verdict, with the explaining document → the evidence) for
    *values* as :func:`measure` returns them."""
    df = rows(values)
    lines = [verdict_counts(df), "",
             "| thesis | where | experiment | the thesis states | reproduced | verdict | evidence and reason |",
             "|---|---|---|---|---|---|---|"]
    for r in df.itertuples(index=False):
        explained = r.status.removeprefix("justified departure: ")
        verdict = r.verdict + (f" ({explained})" if explained != r.status else "")
        lines.append(f"| {r.figure} | {r.source} | `{r.experiment}` | {_fmt(r.thesis)} | {_fmt(r.reproduced)} "
                     f"| {_fmt(verdict)} | {_fmt(r.reason)} |")
    return "\n".join(lines)


def with_table(doc: str, table: str) -> str:
    """*doc* with the text between :data:`BEGIN` and :data:`END` replaced by *table*."""
    i, j = doc.find(BEGIN), doc.find(END)
    if i < 0 or j < i:
        from netcosim.errors import ConfigurationError
        raise ConfigurationError(f"the document lacks the markers {BEGIN!r} ... {END!r}")
    return doc[:i + len(BEGIN)] + "\n" + table + "\n" + doc[j:]


def load(path: str | Path = REPRODUCED) -> dict[str, float]:
    """The stored reproduced numbers (``inf``/``nan`` as JSON strings)."""
    return {k: (v if k.endswith(".host") else float(v)) for k, v in json.loads(Path(path).read_text()).items()}


def save(values: dict[str, float], path: str | Path = REPRODUCED) -> None:
    """Store *values* (sorted keys; non-finite numbers as strings ``"inf"``/``"nan"``)."""
    enc = {k: (v if isinstance(v, str) or math.isfinite(v) else str(v)) for k, v in sorted(values.items())}
    Path(path).write_text(json.dumps(enc, indent=1) + "\n")


def main(argv: list[str] | None = None) -> int:
    """Command line: see the module docstring."""
    lines = __doc__.strip().splitlines()
    ap = argparse.ArgumentParser(prog="python -m netcosim.experiments.fidelity", description=lines[0],
                                 epilog="\n".join(lines[1:]).strip(),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--outdir", default="results", help="parent of the per-experiment folders the experiments "
                    "wrote, as for netcosim.experiments.main (default: results)")
    ap.add_argument("--measure", action="store_true", help="read the experiments' outputs under --outdir and "
                    "store their numbers (default: use the stored numbers)")
    ap.add_argument("--check", action="store_true", help="only compare docs/fidelity.md with the stored numbers")
    a = ap.parse_args(argv)
    if a.measure:
        values = load() if REPRODUCED.exists() else {}
        values.update(measure(a.outdir))
        save(values)
    text = with_table(DOC.read_text(), render(load()))
    if a.check:
        same = text == DOC.read_text()
        print("docs/fidelity.md is up to date" if same else "docs/fidelity.md differs from the stored numbers")
        return 0 if same else 1
    DOC.write_text(text)
    print(render(load()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
