"""Cost of the online gain ``k_h = tau_o(e_h)/T`` (3.26)/(4.30), against the sampling period.

One online gain is one integration of the auxiliary flow (4.17) with event detection
for ``tau_s`` plus the minimisation giving ``tau_o``.  Measured on the 4-robot
non-square Fly-crane of Sec. 4.6 (n = 12, m = 10, ``K_bar = I``, weighted 2-norm with
``D = diag(I_4, 4 I_6)``) at the errors met along the online run of Fig. 4.8 from
``q^0`` = 80 deg, and, for reference, on the 3-robot Fly-crane of Sec. 3.5 (T = 0.01 s).
The baseline measured in the same run is one evaluation of the flow's right-hand side
(Jacobian + least squares); the ratio is the number of right-hand-side evaluations'
worth of time one gain costs.  Run: ``python -m benchmarks.controllers``.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from controllers.local_planner import (OnlineGain, WeightedNorm, _jacobian, _pinv_apply, online_gain,
                                       simulate_sampled)
from plants.flycrane.configurations import four_robot_nonsquare, thesis_flycrane


def _errors_along_online_run(sys_, q0, q_ref, T, norm, n=5):
    df = simulate_sampled(sys_, q0, q_ref, T, OnlineGain(), norm=norm, n_samples=n, tol=1e-9)
    Q = df[[f"q{i}" for i in range(sys_.m)]].values
    return [q for q in Q[:-1]]


def _time_gain(sys_, qs, q_ref, T, norm, repeats):
    times, nfev = [], []
    for _ in range(repeats):
        for q in qs:
            t0 = time.perf_counter()
            _, flow = online_gain(sys_, q, q_ref, T, norm=norm)
            times.append(time.perf_counter() - t0)
            nfev.append(flow.nfev)
    return times, nfev


def _time_rhs(sys_, q, repeats=2000):
    c = np.ones(sys_.n)
    t0 = time.perf_counter()
    for _ in range(repeats):
        _pinv_apply(_jacobian(sys_, q), c, q)
    return (time.perf_counter() - t0) / repeats


def main(repeats: int = 5) -> dict:
    """Print and return median and max of one online gain computation (s)."""
    out = {}
    s4 = four_robot_nonsquare()
    q_ref = s4.q_from([60] * 4, [0] * 6)
    q0 = s4.q_from([80] * 4, [0] * 6)
    norm = WeightedNorm((1.0,) * 4 + (4.0,) * 6, 2)
    T4 = 1.5
    qs = _errors_along_online_run(s4, q0, q_ref, T4, norm)
    times, nfev = _time_gain(s4, qs, q_ref, T4, norm, repeats)
    rhs = _time_rhs(s4, q0)
    med, mx = statistics.median(times), max(times)
    out["4-robot"] = dict(median=med, max=mx, T=T4, rhs=rhs, nfev_median=statistics.median(nfev))
    print(f"online gain tau_o, 4-robot non-square (n=12, m=10), {len(times)} runs at {len(qs)} errors:")
    print(f"  median {med * 1e3:.2f} ms, max {mx * 1e3:.2f} ms; T = {T4} s -> max/T = {mx / T4:.2e}")
    print(f"  baseline: one flow right-hand side {rhs * 1e6:.1f} us; median gain = {med / rhs:.0f} x baseline "
          f"(median {statistics.median(nfev):.0f} RHS evaluations)")

    s3 = thesis_flycrane(cable_length=1.5)
    q_ref3 = s3.q_nominal
    e = 0.4 * np.array([1.0, -1.0, 0.5, 0.5, -0.5, 0.8, 0.3, -0.3, 0.2])
    e /= np.linalg.norm(e) / 0.4
    qs3 = _errors_along_online_run(s3, q_ref3 + e, q_ref3, 0.01, None, n=3)
    times3, _ = _time_gain(s3, qs3, q_ref3, 0.01, None, repeats)
    med3, mx3 = statistics.median(times3), max(times3)
    out["3-robot"] = dict(median=med3, max=mx3, T=0.01)
    print(f"online gain tau_o, 3-robot Fly-crane (n=m=9): median {med3 * 1e3:.2f} ms, max {mx3 * 1e3:.2f} ms; "
          f"T = 0.01 s -> max/T = {mx3 / 0.01:.2f}")
    return out


if __name__ == "__main__":
    main()
