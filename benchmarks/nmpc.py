"""Cost of the landing NMPC: real-time iteration versus a full IPOPT solve.

One closed-loop landing (NMPC alone, nominal model (2.5) discretized by the OCP's own
RK4, 1 s = 100 samples) is run with the RTI.  In the same run, at every visited
state, the same OCP is solved to convergence by IPOPT (warm-started from its previous
solution).  Reported: per-step wall-clock times (median, p99, max) of the RTI
(feedback phase, preparation phase, total) and of IPOPT, and their ratio.  Then the
RTI's total per-step time with the other QP solvers this CasADi build offers, and
the preparation time with the linearization compiled to C (CasADi ``jit``).

The thesis's C implementation (MATMPC + qpOASES) stays under 5 ms per step; the
target here is max <= 5 ms and median <= 2 ms.  Python's garbage collector is
disabled inside the timed loop (as in a real-time process).  Run
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
    """RTI closed loop; optionally an IPOPT solve at each visited state. Times in seconds."""
    ctrl = landing_nmpc(**kw)
    ipopt = ctrl.ipopt_solver() if with_ipopt else None
    x = initial_state()
    fb, prep, tot, ip, ip_iter = [], [], [], [], []
    fails = 0
    gc.collect()
    gc.disable()
    try:
        for _ in range(steps):
            t0 = time.perf_counter()
            r = ctrl.feedback(x)
            t1 = time.perf_counter()
            ctrl.preparation()
            t2 = time.perf_counter()
            fb.append(t1 - t0)
            prep.append(t2 - t1)
            tot.append(t2 - t0)
            fails += r.fallback
            if ipopt is not None:
                s = ipopt.solve(x)
                ip.append(s.t_wall)
                ip_iter.append(s.iterations)
            x = np.asarray(ctrl.ocp.F(x, r.u, ctrl.p)).ravel()
    finally:
        gc.enable()
    return dict(feedback=fb, prepare=prep, total=tot, ipopt=ip, ipopt_iter=ip_iter, fallbacks=fails,
                final_phi_deg=float(np.degrees(x[0])), final_theta_deg=float(np.degrees(x[2])))


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
    and ``host`` (the load when the run started)."""
    h = host()
    parts = []
    for k in range(repeats):
        res = closed_loop(steps, with_ipopt=False)
        parts.append(pd.DataFrame({c: res[c] for c in ("feedback", "prepare", "total")}).assign(repeat=k))
    df = pd.concat(parts, ignore_index=True).assign(host=h)
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    df.to_parquet(out / "rti_times.parquet")
    print(pd.DataFrame({k: _stats(df[k]) for k in ("feedback", "prepare", "total")}).T.round(3).to_string())
    per = df.groupby("repeat")["total"].max() * 1e3
    print(f"max per repeat [ms]: {', '.join(f'{v:.2f}' for v in per)}")
    print(f"host: {df['host'].iloc[0]} -> {out / 'rti_times.parquet'}")
    return df


def main() -> dict:
    res = closed_loop()
    rows = {"RTI feedback (QP)": _stats(res["feedback"]), "RTI preparation": _stats(res["prepare"]),
            "RTI total": _stats(res["total"]), "IPOPT full solve": _stats(res["ipopt"])}
    table = pd.DataFrame(rows).T
    ratio = np.median(res["ipopt"]) / np.median(res["total"])
    print(f"closed-loop landing, {STEPS} samples (final φ = {res['final_phi_deg']:.2f}°, "
          f"ϑ = {res['final_theta_deg']:.2f}°), QP fallbacks: {res['fallbacks']}")
    print(table.round(3).to_string())
    print(f"IPOPT iterations per step: median {np.median(res['ipopt_iter']):.0f}, max {max(res['ipopt_iter'])}")
    print(f"median IPOPT / median RTI = {ratio:.1f}")

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
            c._lin(c._w, c._p)
            ts.append(time.perf_counter() - t1)
        lin[name] = 1e6 * float(np.median(ts))
    print(f"\nlinearization (QP data) median: VM {lin['virtual machine']:.0f} us, "
          f"JIT {lin['jit (gcc -O2)']:.0f} us (compile {t_compile:.1f} s)")
    return dict(table=table, ratio=ratio, solvers=st, linearization_us=lin, jit_compile_s=t_compile)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(prog="python -m benchmarks.nmpc", description=__doc__.splitlines()[0])
    ap.add_argument("--rti-only", action="store_true", help="time the RTI alone and write rti_times.parquet")
    ap.add_argument("--outdir", default="results/nmpc_benchmark", help="where --rti-only writes")
    a = ap.parse_args()
    if a.rti_only:
        write_rti_times(a.outdir)
    else:
        main()
