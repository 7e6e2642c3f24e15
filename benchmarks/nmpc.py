"""Cost of the landing NMPC: real-time iteration versus a full IPOPT solve.

One closed-loop landing (NMPC alone, nominal model (2.5) discretized by the OCP's own
RK4, 1 s = 100 samples) is run with the RTI, ``--repeats`` times (default 3).  In the
same run, at every visited state, the same OCP is solved to convergence by IPOPT
(warm-started from its previous solution).  Reported: per-step times (median, p99, max)
of the RTI's feedback phase, preparation phase and total, and of IPOPT, each as
wall-clock time and as CPU time of the calling thread (``time.thread_time``: what the
step costs, without the time the host's other jobs take the core away), and the ratio
of the medians.  Then, interleaved round by round, the RTI with HPIPM called directly
(the default, :mod:`netcosim.controllers.nmpc.hpipm`) against CasADi's ``hpipm`` plugin
(``direct_hpipm=False``: the same steps bit for bit); the RTI's total per-step time with
the other QP solvers this CasADi build offers; and the preparation time with the
linearization compiled to C (CasADi ``jit``).

Targets (issue 30): RTI median <= 1.0 ms and max <= 2.0 ms, IPOPT >= 10x slower.  The
thesis's C implementation (MATMPC + qpOASES) stays under 5 ms per step.  Python's
garbage collector is disabled inside the timed loop (as in a real-time process).  Run
``python -m benchmarks.nmpc``; ``--rti-only --outdir DIR`` times the RTI alone and
writes its per-step times and the host to ``DIR/rti_times.parquet`` (the NMPC time row
of docs/fidelity.md: ``python -m netcosim.experiments.fidelity --measure`` reads
``results/nmpc_benchmark/``).
"""

from __future__ import annotations

import argparse
import gc
import time
from pathlib import Path

import numpy as np
import pandas as pd

from netcosim.controllers.landing import initial_state, landing_nmpc

STEPS = 100


def _stats(a) -> dict:
    a = np.asarray(a, dtype=float) * 1e3
    return {"median_ms": float(np.median(a)), "p99_ms": float(np.percentile(a, 99)), "max_ms": float(a.max())}


def closed_loop(steps: int = STEPS, with_ipopt: bool = True, **kw) -> dict:
    """RTI closed loop; optionally an IPOPT solve at each visited state.  Times in seconds:
    ``feedback``, ``prepare``, ``total``, ``ipopt`` wall-clock; ``cpu_*`` the same as CPU
    time of this thread (``cpu_ipopt``: of the process, in case IPOPT's BLAS runs threads)."""
    ctrl = landing_nmpc(**kw)
    ipopt = ctrl.ipopt_solver() if with_ipopt else None
    x = initial_state()
    out: dict[str, list] = {k: [] for k in ("feedback", "prepare", "total", "cpu_feedback", "cpu_prepare",
                                            "cpu_total", "ipopt", "cpu_ipopt", "ipopt_iter")}
    fails = 0
    wall, cpu, pcpu = time.perf_counter, time.thread_time, time.process_time
    gc.collect()
    gc.disable()
    try:
        for _ in range(steps):
            c0, t0 = cpu(), wall()
            r = ctrl.feedback(x)
            t1, c1 = wall(), cpu()
            ctrl.preparation()
            t2, c2 = wall(), cpu()
            for key, v in (("feedback", t1 - t0), ("prepare", t2 - t1), ("total", t2 - t0),
                           ("cpu_feedback", c1 - c0), ("cpu_prepare", c2 - c1), ("cpu_total", c2 - c0)):
                out[key].append(v)
            fails += r.fallback
            if ipopt is not None:
                p0 = pcpu()
                s = ipopt.solve(x)
                out["cpu_ipopt"].append(pcpu() - p0)
                out["ipopt"].append(s.t_wall)
                out["ipopt_iter"].append(s.iterations)
            x = np.asarray(ctrl.ocp.F(x, r.u, ctrl.p)).ravel()
    finally:
        gc.enable()
    return dict(out, fallbacks=fails, final_phi_deg=float(np.degrees(x[0])),
                final_theta_deg=float(np.degrees(x[2])))


def _concat(runs: list[dict]) -> dict:
    """The per-step lists of several :func:`closed_loop` runs, joined."""
    keys = [k for k, v in runs[0].items() if isinstance(v, list)]
    return {k: [v for r in runs for v in r[k]] for k in keys} | {"fallbacks": sum(r["fallbacks"] for r in runs)}


def host() -> str:
    """This host, as the time row states it: CPU model, logical cores, 1-min load."""
    import os
    import platform
    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    return f"{cpu}, {os.cpu_count()} logical cores, load {load:.1f}"


def write_rti_times(outdir, steps: int = STEPS, repeats: int = 5) -> pd.DataFrame:
    """Time the RTI closed loop (no IPOPT) *repeats* times and write ``rti_times.parquet``
    to *outdir*: one row per step, ``repeat``, ``feedback``, ``prepare``, ``total`` [s]
    (wall-clock), ``cpu_feedback``, ``cpu_prepare``, ``cpu_total`` [s] (CPU time of the
    thread) and ``host`` (the load when the run started)."""
    h = host()
    parts = []
    cols = ("feedback", "prepare", "total", "cpu_feedback", "cpu_prepare", "cpu_total")
    for k in range(repeats):
        res = closed_loop(steps, with_ipopt=False)
        parts.append(pd.DataFrame({c: res[c] for c in cols}).assign(repeat=k))
    df = pd.concat(parts, ignore_index=True).assign(host=h)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    df.to_parquet(out / "rti_times.parquet")
    print(pd.DataFrame({k: _stats(df[k]) for k in cols}).T.round(3).to_string())
    per = df.groupby("repeat")["total"].max() * 1e3
    print(f"max per repeat [ms]: {', '.join(f'{v:.2f}' for v in per)}")
    print(f"host: {df['host'].iloc[0]} -> {out / 'rti_times.parquet'}")
    return df


def main(repeats: int = 3) -> dict:
    print(f"host: {host()}")
    runs = [closed_loop() for _ in range(repeats)]
    res = _concat(runs)
    rows = {"RTI feedback (QP)": "feedback", "RTI preparation": "prepare", "RTI total": "total",
            "IPOPT full solve": "ipopt"}
    table = pd.DataFrame({f"{label}, {kind}": _stats(res[("cpu_" if kind == "CPU" else "") + key])
                          for label, key in rows.items() for kind in ("wall", "CPU")}).T
    ratio = np.median(res["ipopt"]) / np.median(res["total"])
    ratio_cpu = np.median(res["cpu_ipopt"]) / np.median(res["cpu_total"])
    per_run = [np.median(r["ipopt"]) / np.median(r["total"]) for r in runs]
    print(f"closed-loop landing, {repeats} x {STEPS} samples (final φ = {runs[-1]['final_phi_deg']:.2f}°, "
          f"ϑ = {runs[-1]['final_theta_deg']:.2f}°), QP fallbacks: {res['fallbacks']}")
    print(table.round(3).to_string())
    print(f"IPOPT iterations per step: median {np.median(res['ipopt_iter']):.0f}, max {max(res['ipopt_iter'])}")
    print(f"median IPOPT / median RTI total = {ratio:.1f} (wall; per run {', '.join(f'{v:.1f}' for v in per_run)}), "
          f"{ratio_cpu:.1f} (CPU)")

    # the same closed loop, HPIPM direct against CasADi's plugin, interleaved round by round
    ab: dict[str, list] = {"direct": [], "plugin": []}
    for _ in range(repeats):
        for name, direct in (("direct", True), ("plugin", False)):
            ab[name].append(closed_loop(with_ipopt=False, direct_hpipm=direct))
    abt = pd.DataFrame({f"{name}, {ph}": _stats(_concat(r)[f"cpu_{ph}"])
                        for name, r in ab.items() for ph in ("feedback", "prepare", "total")}).T
    print(f"\nRTI CPU time per step, HPIPM called directly vs CasADi's hpipm plugin ({repeats} interleaved rounds):")
    print(abt.round(3).to_string())

    solvers = {}
    for qp in ("hpipm", "qpoases", "daqp", "proxqp", "osqp"):
        try:
            r = closed_loop(with_ipopt=False, qp_solver=qp)
        except Exception as exc:  # a plugin missing from this CasADi build
            print(f"{qp}: unavailable ({exc})")
            continue
        solvers[qp] = {**_stats(r["total"]), "fallbacks": r["fallbacks"]}
    st = pd.DataFrame(solvers).T
    print("\nRTI total per step by QP solver (same closed loop):")
    print(st.round(3).to_string())

    t0 = time.perf_counter()
    jit = landing_nmpc(jit=True)
    t_compile = time.perf_counter() - t0
    vm = landing_nmpc()
    lin = {}
    for name, c in (("virtual machine", vm), ("jit (gcc -O2)", jit)):
        ts = []
        for _ in range(300):
            t1 = time.perf_counter()
            c._lin_buf(c._w, c._p)
            ts.append(time.perf_counter() - t1)
        lin[name] = 1e6 * float(np.median(ts))
    print(f"\nlinearization (QP data, into preallocated buffers) median: VM {lin['virtual machine']:.0f} us, "
          f"JIT {lin['jit (gcc -O2)']:.0f} us (compile {t_compile:.1f} s)")
    return dict(table=table, ratio=ratio, ratio_cpu=ratio_cpu, direct_vs_plugin=abt, solvers=st,
                linearization_us=lin, jit_compile_s=t_compile)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(prog="python -m benchmarks.nmpc", description=__doc__.splitlines()[0])
    ap.add_argument("--rti-only", action="store_true", help="time the RTI alone and write rti_times.parquet")
    ap.add_argument("--outdir", default="results/nmpc_benchmark", help="where --rti-only writes")
    ap.add_argument("--repeats", type=int, default=None,
                    help="closed loops of 100 samples (default: 3; with --rti-only: 5)")
    a = ap.parse_args()
    if a.rti_only:
        write_rti_times(a.outdir, repeats=a.repeats or 5)
    else:
        main(repeats=a.repeats or 3)
