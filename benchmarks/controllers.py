"""Cost of the online gain ``k_h = tau_o(e_h)/T`` (3.26)/(4.30), against the sampling period.

One online gain is one integration of the auxiliary flow (4.17) up to the return time
``tau_s`` plus the minimisation giving ``tau_o`` (``online_gain``).  Measured at the
errors met along the online runs of the experiments:

* the 4-robot non-square Fly-crane of Sec. 4.6 (n = 12, m = 10, ``K_bar = I``, weighted
  2-norm with ``D = diag(I_4, 4 I_6)``), online run of Fig. 4.8 from ``q^0`` = 80 deg,
  T = 1.5 s;
* the 3-robot Fly-crane of Sec. 3.5 (n = m = 9), online run of Fig. 3.8 from an error of
  norm 0.4, T = 0.01 s.

Both are compared with T = 0.01 s, the shortest period of the experiments.  Each gain is
timed on its own (``time.perf_counter``) ``repeats`` times per error; median and max are
over all of them.  For reference the same gains are timed with the flow's functions run
in CasADi's virtual machine (no C compiler) and with the SVD right-hand side used for
kinematic systems without a CasADi Jacobian.  Run: ``python -m benchmarks.controllers``.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

import netcosim.plants.casadi_tools as casadi_tools
from netcosim.controllers.planner import OnlineGain, WeightedNorm, online_gain, simulate_sampled
from netcosim.plants.flycrane.configurations import four_robot_nonsquare, thesis_flycrane

#: The shortest sampling period of the experiments (Fig. 3.8), s.
T_MIN = 0.01


class _NumericOnly:
    """A system seen through ``n, m, h, jacobian`` only: the flow uses the SVD right-hand side."""

    def __init__(self, system):
        self.n, self.m, self.h, self.jacobian = system.n, system.m, system.h, system.jacobian


def _errors_along_online_run(sys_, q0, q_ref, T, norm, n):
    df = simulate_sampled(sys_, q0, q_ref, T, OnlineGain(), norm=norm, n_samples=n, tol=1e-9)
    return list(df[[f"q{i}" for i in range(sys_.m)]].values[:-1])


def _time_gain(sys_, qs, q_ref, T, norm, repeats):
    times, nfev = [], []
    for q in qs:
        online_gain(sys_, q, q_ref, T, norm=norm)  # first use prepares the flow
    for _ in range(repeats):
        for q in qs:
            t0 = time.perf_counter()
            _, flow = online_gain(sys_, q, q_ref, T, norm=norm)
            times.append(time.perf_counter() - t0)
            nfev.append(flow.nfev)
    return times, nfev


def _case(label, make, q0_q_ref, T, norm, n_samples, repeats, out):
    sys_ = make()
    q0, q_ref = q0_q_ref(sys_)
    qs = _errors_along_online_run(sys_, q0, q_ref, T, norm, n_samples)
    times, nfev = _time_gain(sys_, qs, q_ref, T, norm, repeats)
    med, mx = statistics.median(times), max(times)
    casadi_tools.COMPILE = False  # a fresh system prepares its flow without compiling
    try:
        vm, _ = _time_gain(make(), qs, q_ref, T, norm, max(1, repeats // 4))
    finally:
        casadi_tools.COMPILE = True
    svd, _ = _time_gain(_NumericOnly(sys_), qs, q_ref, T, norm, max(1, repeats // 4))
    out[label] = dict(median=med, max=mx, T=T, nfev_median=statistics.median(nfev), n=len(times),
                      vm_median=statistics.median(vm), vm_max=max(vm),
                      svd_median=statistics.median(svd), svd_max=max(svd))
    errs = ", ".join(f"{np.linalg.norm(q - q_ref):.1e}" for q in qs)
    print(f"online gain tau_o, {label}: {len(times)} runs at {len(qs)} errors (||e_h|| = {errs})")
    print(f"  median {med * 1e3:.2f} ms, max {mx * 1e3:.2f} ms; T = {T} s -> max/T = {mx / T:.2e}"
          + (f", max/{T_MIN} s = {mx / T_MIN:.3f}" if T != T_MIN else ""))
    print(f"  median {statistics.median(nfev):.0f} right-hand-side evaluations; same gains with the "
          f"functions uncompiled: median {out[label]['vm_median'] * 1e3:.2f} ms, max {max(vm) * 1e3:.2f} ms; "
          f"SVD right-hand side: median {out[label]['svd_median'] * 1e3:.2f} ms, max {max(svd) * 1e3:.2f} ms")


def main(repeats: int = 40) -> dict:
    """Print and return median and max (s) of one online gain computation."""
    out = {}
    norm4 = WeightedNorm((1.0,) * 4 + (4.0,) * 6, 2)

    def start4(s):
        return s.q_from([80] * 4, [0] * 6), s.q_from([60] * 4, [0] * 6)

    _case("4-robot non-square (n=12, m=10)", four_robot_nonsquare, start4, 1.5, norm4, 5, repeats, out)

    def start3(s):
        e = np.array([1.0, -1.0, 0.5, 0.5, -0.5, 0.8, 0.3, -0.3, 0.2])
        return s.q_nominal + 0.4 * e / np.linalg.norm(e), s.q_nominal

    _case("3-robot Fly-crane (n=m=9)", lambda: thesis_flycrane(cable_length=1.5), start3, T_MIN, None, 3,
          repeats, out)
    return out


if __name__ == "__main__":
    main()
