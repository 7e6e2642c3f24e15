"""Plant evaluation cost: Fly-crane dynamics right-hand sides and RK4 steps.

Baseline (measured in the same run): a plain NumPy evaluation of the thesis Fly-crane
kinematics h(q) (B.2), written by hand with 3×3 rotation matrices.  Every other
timing is reported as a ratio to it, because absolute wall-clock numbers on shared
machines are noisy.

Measured, for the 3-robot Fly-crane (n = m = 9) and the 4-robot system (n = 12, m = 10):

* the CasADi kinematics ``h_fun`` / ``A_fun`` through the numpy wrappers (CasADi's
  buffer interface, :class:`netcosim.plants.casadi_tools.BufferedFunction`), and ``h_fun`` called the plain way (with
  DM conversions) to show what the buffer interface saves;
* the dynamics right-hand side of :class:`ForcePlant` (4.10) and of
  :class:`VelocityTrackingPlant` (4.10)-(4.11) with gravity compensation;
* one classical RK4 step of the velocity-tracking plant (4 right-hand sides);
* the tethered-UAV simulation model (2.5)+(2.17) right-hand side for comparison.

Run: ``python -m benchmarks.plants``.
"""

from __future__ import annotations

import math
import time

import numpy as np

from netcosim.plant import RK4
from netcosim.plants.flycrane import configurations as C
from netcosim.plants.flycrane.input_modes import ForcePlant, VelocityTrackingPlant
from netcosim.plants.tethered_uav import TetheredUAV, TetheredUAVParams


def _rot(phi, theta, psi):
    c, s = math.cos, math.sin
    Rz = np.array([[c(phi), -s(phi), 0], [s(phi), c(phi), 0], [0, 0, 1]])
    Ry = np.array([[c(theta), 0, s(theta)], [0, 1, 0], [-s(theta), 0, c(theta)]])
    Rx = np.array([[1, 0, 0], [0, c(psi), -s(psi)], [0, s(psi), c(psi)]])
    return Rz @ Ry @ Rx


def numpy_flycrane_h(q, l=1.5, edge=1.0):
    """Baseline: (B.2) for the thesis Fly-crane in plain NumPy."""
    l_C = edge / (2 * math.sqrt(3))
    r = l * math.sqrt(1 - (edge / (2 * l)) ** 2)
    R = _rot(q[6], q[7], q[8])
    out = np.empty(9)
    for i in range(3):
        s = 2 * math.pi * i / 3
        a = q[i]
        loc = np.array([0.0, l_C + r * math.cos(a), r * math.sin(a)])
        Rs = np.array([[math.cos(s), -math.sin(s), 0], [math.sin(s), math.cos(s), 0], [0, 0, 1]])
        out[3 * i:3 * i + 3] = q[3:6] + R @ (Rs @ loc)
    return out


def _per_call(fn, min_time=0.2, repeats=5) -> float:
    """Median over *repeats* of the mean time per call [s] (each repeat ≥ min_time)."""
    n = 1
    while True:
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        dt = time.perf_counter() - t0
        if dt >= min_time / 4:
            break
        n *= 2
    n = max(1, int(n * (min_time / max(dt, 1e-9))))
    res = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(n):
            fn()
        res.append((time.perf_counter() - t0) / n)
    return float(np.median(res))


def main() -> None:
    rows = []
    fc3 = C.thesis_flycrane()
    q3 = fc3.q_nominal
    assert np.allclose(numpy_flycrane_h(q3), fc3.h(q3), atol=1e-12)
    base = _per_call(lambda: numpy_flycrane_h(q3))
    rows.append(("baseline: NumPy h(q), 3 robots", base))

    for label, sys in (("3 robots", fc3), ("4 robots", C.four_robot_nonsquare())):
        q = sys.q_nominal
        rng = np.random.default_rng(0)
        fp, vp = ForcePlant(sys), VelocityTrackingPlant(sys, 100.0)
        x = vp.initial_state(q, rng.normal(scale=0.1, size=sys.m))
        u = sys.jacobian(q) @ rng.normal(scale=0.1, size=sys.m)
        F = np.asarray(sys.dynamics.gravity_compensation_fun(q)).ravel()
        rows.append((f"CasADi h(q), {label}", _per_call(lambda: sys.h(q))))
        rows.append((f"  same via plain Function call (DM), {label}", _per_call(lambda: sys.h_fun(q))))
        rows.append((f"CasADi A_q(q), {label}", _per_call(lambda: sys.jacobian(q))))
        rows.append((f"pinv(q) (SVD), {label}", _per_call(lambda: sys.pinv(q))))
        rows.append((f"dynamics rhs, force input, {label}", _per_call(lambda: fp.f(0.0, x, F, None))))
        rows.append((f"dynamics rhs, velocity tracking, {label}", _per_call(lambda: vp.f(0.0, x, u, None))))
        rhs = lambda t, x: vp.f(t, x, u, None)  # noqa: E731
        rows.append((f"RK4 step, velocity tracking, {label}", _per_call(lambda: RK4.step(rhs, 0.0, x, 1e-3))))

    p = TetheredUAVParams()
    uav = TetheredUAV(p)
    xu = np.array([0.3, 0.1, 0.2, 0.0, 9.0, 0.1])
    uu = np.zeros(4)
    rows.append(("tethered UAV rhs (2.5)+(2.17)", _per_call(lambda: uav.f(0.0, xu, uu, p))))

    w = max(len(r[0]) for r in rows)
    print(f"{'measurement':<{w}}  {'time/call':>11}  {'x baseline':>10}")
    for name, t in rows:
        print(f"{name:<{w}}  {t * 1e6:9.1f} us  {t / base:10.1f}")


if __name__ == "__main__":
    main()
