"""The "realistic environment" of thesis Fig. 5.6 for the SIKM strategies of ch. 5.

The thesis runs Figs. 5.8/5.9 on a Gazebo model: the SIKM controller sends the desired
robot velocities every T, each robot's low-level controller turns them into thrust, and
an unscented Kalman filter (UKF) fuses the motion-capture (MoCap) measurements with the
IMU; the controller reads the UKF's estimate.  Here:

* plant: the Lagrangian model (4.10) under the velocity-tracking force (4.11),
  ``F = -alpha (A_q q_dot - u) + F_g(q)`` (:class:`netcosim.plants.flycrane.input_modes.VelocityTrackingPlant`,
  compiled as in :class:`netcosim.controllers.planner.plant_models.VelocityTrackingModel`), integrated
  with LSODA between MoCap instants;
* the law (5.13)/(5.14)/(5.15) is evaluated at the MoCap rate and held in between (the
  robots receive a velocity every ``1/mocap_rate`` s; the feedback part changes only every T);
* MoCap: every ``1/mocap_rate`` s the configuration q plus Gaussian noise of standard
  deviation ``noise_std`` (rad for angles, m for lengths) on every coordinate;
* UKF: :class:`filterpy.kalman.UnscentedKalmanFilter` (Van der Merwe sigma points)
  with state q, process model the kinematic model ``q+ = q + dt A_q^{-1} u`` with the
  applied u (the model the controller assumes), measurement q.  There is no IMU in the
  simulation (the robots are point masses), so the filter fuses the MoCap stream with the
  commanded velocities instead.  ``filterpy`` is a well-kept library; its UKF is used as
  is.

:class:`RealisticEnvironment` holds these settings; :meth:`RealisticEnvironment.track`
runs a Table 5.1 strategy and returns the same ``(samples, dense)`` tables as
:func:`netcosim.controllers.planner.sikm.simulate_tracking`; :meth:`RealisticEnvironment.interval_samples`
gives the one-period samples of the QP (5.27) on the dynamic model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from netcosim import validate
from netcosim.errors import ConfigurationError

from .flow import online_gain
from .kinematics import as_vector, check_period
from .norms import WeightedNorm
from .sikm import SIKMParams, Strategy, Trajectory, checked_tracking_run, sikm_velocity

__all__ = ["RealisticEnvironment"]


@dataclass(frozen=True)
class RealisticEnvironment:
    """Settings of the Fig. 5.6 environment (every value in SI units).

    ``alpha`` (N s/m, > 0): velocity-tracking gain of (4.11) (a 1.03 kg robot tracks a
    velocity step with time constant ``1.03/alpha`` s).  ``mocap_rate`` (Hz, > 0): rate of
    the MoCap measurements, of the UKF update and of the velocity commands (thesis: 120 Hz).
    ``noise_std`` (rad / m, >= 0): standard deviation of the MoCap noise on every
    coordinate of q (thesis Fig. 5.9: 0.003, and 0.01).  ``process_std`` (rad / m per
    sqrt(s), > 0): the UKF's process-noise density: ``Q = process_std^2 dt I``.
    ``use_filter``: the controller reads the UKF's estimate (True) or the raw MoCap sample
    (False).  ``rtol``, ``atol``: LSODA tolerances of the plant.
    """

    alpha: float = 30.0
    mocap_rate: float = 120.0
    noise_std: float = 0.003
    process_std: float = 0.02
    use_filter: bool = True
    rtol: float = 1e-8
    atol: float = 1e-10

    def __post_init__(self):
        for nm, kind in (("alpha", "a positive number (N s/m)"), ("mocap_rate", "a positive number (Hz)"),
                         ("process_std", "a positive number (rad or m per sqrt(s))")):
            object.__setattr__(self, nm, validate.positive(getattr(self, nm), f"RealisticEnvironment {nm}",
                                                           kind=kind, type_error=ConfigurationError))
        object.__setattr__(self, "noise_std", validate.non_negative(
            self.noise_std, "RealisticEnvironment noise_std", kind="finite and >= 0 (rad or m)",
            type_error=ConfigurationError))

    # -- building blocks --------------------------------------------------------------
    def plant(self, system: Any):
        """The velocity-tracking dynamic plant of *system* (no events; compiled when a C compiler exists)."""
        from .plant_models import VelocityTrackingModel
        return VelocityTrackingModel(self.alpha, rtol=self.rtol, atol=self.atol).build(system, system.name)

    def _advance(self, plant, x, u, dt):
        from scipy.integrate import solve_ivp
        sol = solve_ivp(lambda t, y: plant.f(t, y, u, None), (0.0, dt), x, method="LSODA",
                        rtol=self.rtol, atol=self.atol)
        if sol.status != 0:
            raise RuntimeError(f"dynamic plant integration failed: {sol.message}")
        return sol.y[:, -1]

    def _filter(self, system, q0):
        try:
            from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
        except ImportError as exc:
            raise ImportError("the realistic environment's UKF needs filterpy: pip install 'netcosim[filter]' "
                              f"({exc})") from None
        m = system.m
        dt = 1.0 / self.mocap_rate

        def fx(q, dt, u):
            return q + dt * np.linalg.solve(system.jacobian(q), u)

        pts = MerweScaledSigmaPoints(m, alpha=1e-3, beta=2.0, kappa=0.0)
        ukf = UnscentedKalmanFilter(dim_x=m, dim_z=m, dt=dt, hx=lambda q: q, fx=fx, points=pts)
        ukf.x = np.array(q0, dtype=float)
        r = max(self.noise_std, 1e-6)
        ukf.P = np.eye(m) * r * r
        ukf.R = np.eye(m) * r * r
        ukf.Q = np.eye(m) * self.process_std ** 2 * dt
        return ukf

    # -- closed loop ------------------------------------------------------------------
    def track(self, system: Any, trajectory: Trajectory, q0: Any, T: float, duration: float,
              strategy: Strategy | int, *, k_off: float | None = None, params: SIKMParams | None = None,
              seed: int = 0, n_dense: int = 10):
        """Run a Table 5.1 strategy for ``duration`` s with period T (s) from ``q0`` at rest.

        Every T the controller reads the estimate ``q_hat(hT)`` (UKF, or the raw MoCap
        sample without filter) and picks the gain (*system*: the Fly-crane system, *trajectory*:
        the reference to track): ``k_off`` (1/s, checked against the
        stability set of ``params`` when given) or the online ``tau_o(e_h)/T`` (5.12) on
        ``q_hat``.  ``seed`` seeds the MoCap noise.

        Returns ``(samples, dense)`` like :func:`netcosim.controllers.planner.sikm.simulate_tracking`:
        ``samples``: ``h, t, k, err, err_est`` and ``q*`` (true q at hT); ``dense``:
        ``t, err, err_est``, ``q*``, ``qr*``, ``qhat*`` on ``n_dense`` points per period.
        ``err`` is the true ``||q - q_r||``, ``err_est`` that of the estimate.
        """
        import pandas as pd

        strategy, T, duration = checked_tracking_run(strategy, T, duration, k_off, params)
        m = system.m
        q0 = as_vector(q0, m, "q0")
        plant = self.plant(system)
        x = plant.initial_state(q0)
        rng = np.random.default_rng(seed)
        dt = 1.0 / self.mocap_rate
        per = max(1, int(round(T / dt)))
        if abs(per * dt - T) > 1e-9 * T:
            raise ConfigurationError(f"period T={T} s is not a multiple of the MoCap interval 1/{self.mocap_rate} s")
        n_steps = int(math.floor(duration / T + 1e-9))
        dense_every = max(1, per // n_dense)
        ukf = self._filter(system, q0) if self.use_filter else None
        qhat = q0.copy()
        u = np.zeros(system.n)
        srows, drows = [], []
        for h in range(n_steps + 1):
            t0 = h * T
            qr_h, _ = trajectory(t0)
            q = x[:m]
            e, e_est = float(np.linalg.norm(q - qr_h)), float(np.linalg.norm(qhat - qr_h))
            if h == n_steps:
                srows.append((h, t0, np.nan, e, e_est, *q))
                drows.append((t0, e, e_est, *q, *qr_h, *qhat))
                break
            if strategy.gain == "online":
                k, _ = online_gain(system, qhat, qr_h, T)
            else:
                k = float(k_off)
            srows.append((h, t0, k, e, e_est, *q))
            q_h = qhat.copy()
            for j in range(per):
                t = t0 + j * dt
                qr_t, qrd_t = trajectory(t)
                if j % dense_every == 0:
                    drows.append((t, float(np.linalg.norm(x[:m] - qr_t)), float(np.linalg.norm(qhat - qr_t)),
                                  *x[:m], *qr_t, *qhat))
                u = sikm_velocity(system, q_h, qr_h, k, qr_t, qrd_t, strategy.feedforward)
                x = self._advance(plant, x, u, dt)
                z = x[:m] + self.noise_std * rng.standard_normal(m)
                if ukf is None:
                    qhat = z
                else:
                    ukf.predict(u=u)
                    ukf.update(z)
                    qhat = np.array(ukf.x, dtype=float)
        samples = pd.DataFrame(srows, columns=["h", "t", "k", "err", "err_est"] + [f"q{i}" for i in range(m)])
        dense = pd.DataFrame(drows, columns=["t", "err", "err_est"] + [f"q{i}" for i in range(m)]
                             + [f"qr{i}" for i in range(m)] + [f"qhat{i}" for i in range(m)])
        return samples, dense

    def interval_samples(self, system: Any, trajectory: Trajectory, pairs, starts, radius: float,
                         n_per: int = 1, *, seed: int = 0, feedforward: str = "reference",
                         errors: str = "truth"):
        """One-period samples ``(k, T, ||e_h||, ||e_{h+1}||)`` of the QP (5.27) on the dynamic plant.

        As :func:`netcosim.controllers.planner.sikm.collect_interval_samples`, but the platform starts
        at ``q_r(t0) + e0`` moving with the reference (``q_dot(t0) = q_r_dot(t0)``) and the
        law is applied to a MoCap sample of ``q(t0)`` (noise ``noise_std``, seeded by
        ``seed``) through the MoCap-rate hold and the velocity-tracking robots.
        ``errors``: the two norms are taken on the true configuration ("truth", what a
        simulator offers) or on MoCap samples ("mocap", what an experimenter on the rig
        has); "both" returns the true norms as ``e_h``, ``e_next`` and the MoCap ones as
        ``e_h_mocap``, ``e_next_mocap`` from the same runs (the noise draws, hence the
        runs, are the same for every choice).  T must be a multiple of ``1/mocap_rate``.
        *system*, *trajectory*, *pairs* (gain/period pairs, 1/s and s), *starts* (s),
        *radius*, *n_per* and *feedforward* as for ``collect_interval_samples``.
        """
        import pandas as pd

        validate.choice(errors, "errors", ("truth", "mocap", "both"))

        rng = np.random.default_rng(seed)
        nrm = WeightedNorm()
        m = system.m
        plant = self.plant(system)
        dt = 1.0 / self.mocap_rate
        rows = []
        for (k, T) in pairs:
            T = check_period(T)
            per = int(round(T / dt))
            for t0 in starts:
                qr0, qrd0 = trajectory(t0)
                for e0 in nrm.sample_ball(rng, m, radius, n_per):
                    x = plant.initial_state(qr0 + e0, qrd0)
                    z0 = x[:m] + self.noise_std * rng.standard_normal(m)
                    for j in range(per):
                        qr_t, qrd_t = trajectory(t0 + j * dt)
                        u = sikm_velocity(system, z0, qr0, k, qr_t, qrd_t, feedforward)
                        x = self._advance(plant, x, u, dt)
                    z1 = x[:m] + self.noise_std * rng.standard_normal(m)
                    qr1, _ = trajectory(t0 + per * dt)
                    truth = (float(np.linalg.norm((qr0 + e0) - qr0)), float(np.linalg.norm(x[:m] - qr1)))
                    mocap = (float(np.linalg.norm(z0 - qr0)), float(np.linalg.norm(z1 - qr1)))
                    rows.append((float(k), T, float(t0)) + (mocap if errors == "mocap" else truth)
                                + (mocap if errors == "both" else ()))
        cols = ["k", "T", "t0", "e_h", "e_next"] + (["e_h_mocap", "e_next_mocap"] if errors == "both" else [])
        return pd.DataFrame(rows, columns=cols)
