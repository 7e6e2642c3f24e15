"""The networked Fly-crane of thesis §4.6.1 and appendix A: the ch. 4 planners on five
nodes (the load and four robots) talking over one lossy IEEE 802.11b network.

:class:`FlyCraneNetworkConfig` describes one run (every value documented on the class);
:func:`build` wires it inside a :class:`netcosim.Simulation` with
:func:`netcosim.controllers.planner.tasks.deploy`; :func:`run` runs it and returns a
:class:`FlyCraneRun` (named fields, ``.to_pandas()``, ``.plot()``).

The system is the 4-robot non-square one of Fig. 4.3a / A.1
(:func:`netcosim.plants.flycrane.configurations.four_robot_nonsquare`: N = 4, m = 10, n = 12),
``q0`` = (80 deg x 4, 0 x 6), ``q^r`` = (60 deg x 4, 0 x 6), T = 1.5 s, ``K_bar = I_10``.

Strategies (appendix A):

* ``"offline"``: every T the load (node ``pivot``) reads its pose ``q_V`` and sends it;
  each robot reads its own ``q_i``, computes ``u_i`` with the offline gain (sparse law
  (3.10)) and applies it; a lost message leaves the last ``u_i`` applied.
* ``"online"``: every T the load reads the whole ``q``, computes the online gain
  ``tau_o(e_h)/T`` and ``u`` and sends it; robot i applies its part.  A watchdog task on
  each robot runs every 0.2 s and zeroes the robot's desired velocity once the last
  message is older than T.

Messages: ``"broadcast"`` (default): one frame per period to every robot, no ACK, no
retry, the loss drawn independently per receiver, so the configured probability is the
probability that a robot misses a period's message (what Fig. 4.11's "packet loss
probability" means).  ``"unicast"``: one frame per robot, acknowledged and retried up to
TrueTime's retry limit (5 retries = 6 attempts), so a message is lost with ``loss**6``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from netcosim import Simulation, validate
from netcosim.errors import ConfigurationError
from netcosim.plant import SolveIVP

from .laws import OfflineGain, OnlineGain
from .norms import WeightedNorm
from .plant_dop853 import CompiledDOP853
from .plant_models import KinematicModel, VelocityTrackingModel
from .tasks import Deployment, DeploymentConfig, PlannerLaw, deploy

__all__ = ["FlyCraneNetworkConfig", "FlyCraneRun", "build", "run", "offline_gain", "d_weights", "STRATEGIES",
           "MESSAGINGS", "PLANTS", "D_READINGS", "PHY_RATE", "THESIS_RATE", "ROBOTS", "setting", "GridRecorder"]

STRATEGIES = ("offline", "online")
MESSAGINGS = ("broadcast", "unicast")
PLANTS = ("kinematic", "dynamic")
#: The two readings of the thesis's ``D = diag(I_4, 4 I_6)`` (see :func:`d_weights`).
D_READINGS = ("literal", "assumption")
#: The data rate §4.6.1 quotes (bit/s); TrueTime accepts any rate.
THESIS_RATE = 1.2e6
#: The nearest 802.11b PHY rate (bit/s; the DQPSK rate 2 Mbit/s and DBPSK 1 Mbit/s bracket 1.2).
PHY_RATE = 1e6
#: Robot node names, in the order of the robots in q.
ROBOTS = ("robot1", "robot2", "robot3", "robot4")


def d_weights(reading: str) -> tuple[float, ...]:
    """The diagonal of D that multiplies the error, ``||e||_D = ||D e||_2``.

    ``"literal"``: ``D = diag(I_4, 4 I_6)`` as printed in §4.6: cable-angle errors weigh
    1, pose errors 4 (the reading of the project's Figs. 4.8-4.10).  It contradicts
    (4.9) read with the definition ``D_V = I / d_V^2`` (it would need ``d_V = 1/2 < 1``);
    the gain design here uses the induced norm of ``I - tau K_bar``, which is valid for
    any diagonal weights, so (4.9) is not needed.  ``"assumption"``: the ``d`` of (4.9)
    are (1, 1, 1, 1, 4, ..., 4), so ``D = diag(I_4, I_6 / 16)``: pose errors weigh 1/16.
    """
    if reading == "literal":
        return (1.0,) * 4 + (4.0,) * 6
    if reading == "assumption":
        return (1.0,) * 4 + (1.0 / 16.0,) * 6
    raise ConfigurationError(f"d_reading must be one of {D_READINGS}, got {reading!r}")


def _choice(value, name, options):
    if value not in options:
        raise ConfigurationError(f"{name} must be one of {options}, got {value!r}")
    return value


def _seconds(value, name, *, zero=True):
    v = validate.non_negative(value, name, kind="a non-negative number of seconds", type_error=ConfigurationError) \
        if zero else validate.positive(value, name, kind="a positive number of seconds", type_error=ConfigurationError)
    if not math.isfinite(v):
        raise ConfigurationError(f"{name} must be finite, got {value!r}")
    return float(v)


@dataclass(frozen=True)
class FlyCraneNetworkConfig:
    """One run of the networked Fly-crane (thesis §4.6.1, appendix A).

    ``strategy``: ``"offline"`` or ``"online"`` (module docstring).  ``loss``: probability
    in [0, 1] that a frame is lost at one receiver (drawn independently per frame and
    receiver; with ``"broadcast"`` it is the probability that a robot misses a period's
    message).  ``messaging``: ``"broadcast"`` or ``"unicast"`` (``retry_limit`` retries,
    i.e. ``retry_limit + 1`` attempts; TrueTime's default 5).  ``plant``: ``"kinematic"``
    (``q_dot = A_q^+ u``) or ``"dynamic"`` (the Lagrangian model (4.10) under the
    velocity-tracking force (4.11), ``alpha`` in N s/m, starting at rest).
    ``data_rate`` (bit/s): default :data:`THESIS_RATE` 1.2 Mbit/s; :data:`PHY_RATE`
    1 Mbit/s is the nearest real 802.11b rate.  ``T`` (s): period of the load's task.
    ``q0_deg``, ``qr_deg``: initial and reference cable angles (deg, load pose 0).
    ``d_reading``: which reading of D (:func:`d_weights`) the gains use.
    Execution times (s, constant): ``exec_pose`` (offline: the load reads and sends
    q_V), ``exec_planner`` (online: the load computes the online gain and u),
    ``exec_robot`` (a robot processes a message: offline it computes u_i), ``exec_watchdog``.
    The thesis gives none; ours are an embedded CPU's order of magnitude (the online
    gain solves the auxiliary flow (4.17): 1 ms in Python on the development machine).
    ``watchdog_period`` (s, 0.2 in appendix A); the watchdog zeroes a command older than T.
    ``size_bits``: bits per float in a message.  ``horizon`` (s): simulated time.
    ``sample_dt`` (s): grid of the recorded time series.  ``k_offline`` (1/s): the
    offline gain; None designs it (:func:`offline_gain`, ``n_mu`` Monte-Carlo samples).
    ``seed``: root seed of the simulation (frame losses, backoffs).
    ``schedules``: record the kernels' ``schedule`` and ``jobs`` tables, the
    network's ``network_schedule`` (Figs. A.4/A.5) and the plant's ``signals`` (its
    states, inputs and outputs at every read and write); False switches those traces off
    (``FlyCraneRun.schedule``, ``jobs`` and ``network_schedule`` are then empty, and the
    plant's outputs are not evaluated for a log), which a sweep run does: its metrics read
    only the time series (the recorder's grid) and the ``frames`` table.
    """

    strategy: str = "offline"
    loss: float = 0.0
    messaging: str = "broadcast"
    plant: str = "dynamic"
    alpha: float = 30.0
    data_rate: float = THESIS_RATE
    retry_limit: int = 5
    T: float = 1.5
    q0_deg: float = 80.0
    qr_deg: float = 60.0
    d_reading: str = "literal"
    exec_pose: float = 0.5e-3
    exec_planner: float = 5e-3
    exec_robot: float = 1e-3
    exec_watchdog: float = 0.1e-3
    watchdog_period: float = 0.2
    size_bits: int = 64
    horizon: float = 30.0
    sample_dt: float = 0.1
    k_offline: float | None = None
    n_mu: int = 200
    seed: int = 0
    schedules: bool = True

    def __post_init__(self):
        _choice(self.strategy, "strategy", STRATEGIES)
        _choice(self.messaging, "messaging", MESSAGINGS)
        _choice(self.plant, "plant", PLANTS)
        _choice(self.d_reading, "d_reading", D_READINGS)
        object.__setattr__(self, "loss", validate.probability(self.loss, "loss (per-frame loss probability)",
                                                             type_error=ConfigurationError))
        for nm in ("alpha", "data_rate", "T", "watchdog_period", "horizon", "sample_dt"):
            v = validate.positive(getattr(self, nm), nm, kind="a positive number", type_error=ConfigurationError)
            if not math.isfinite(v):
                raise ConfigurationError(f"{nm} must be finite, got {getattr(self, nm)!r}")
            object.__setattr__(self, nm, float(v))
        for nm in ("exec_pose", "exec_planner", "exec_robot", "exec_watchdog"):
            object.__setattr__(self, nm, _seconds(getattr(self, nm), nm))
        validate.integer(self.retry_limit, "retry_limit (retries)", lo=0, kind="a non-negative integer",
                         type_error=ConfigurationError)
        validate.integer(self.size_bits, "size_bits", lo=1, kind="a positive integer", type_error=ConfigurationError)
        validate.integer(self.n_mu, "n_mu", lo=1, kind="a positive integer", type_error=ConfigurationError)
        validate.integer(self.seed, "seed", lo=0, kind="a non-negative integer", type_error=ConfigurationError)
        for nm in ("q0_deg", "qr_deg"):
            object.__setattr__(self, nm, validate.real(getattr(self, nm), nm, lo=0.0, hi=180.0, lo_open=True,
                                                       hi_open=True, kind="an angle in (0, 180) deg",
                                                       type_error=ConfigurationError))
        if not isinstance(self.schedules, bool):
            raise ConfigurationError(f"schedules must be True or False, got {self.schedules!r}")
        if self.k_offline is not None:
            validate.positive(self.k_offline, "k_offline (1/s)", kind="a positive number",
                              type_error=ConfigurationError)

    def replace(self, **changes) -> "FlyCraneNetworkConfig":
        """A copy with *changes* (validated again)."""
        return FlyCraneNetworkConfig(**{**asdict(self), **changes})

    @property
    def norm(self) -> WeightedNorm:
        """The weighted 2-norm ``||D e||_2`` the gains use (:func:`d_weights`)."""
        return WeightedNorm(d_weights(self.d_reading), 2)


def setting(config: FlyCraneNetworkConfig):
    """``(system, q0, q_ref)`` of the configuration *config* (a :class:`FlyCraneNetworkConfig`;
    rad, m)."""
    sys_ = _system()
    q0 = sys_.q_from([config.q0_deg] * 4, [0] * 6)
    q_ref = sys_.q_from([config.qr_deg] * 4, [0] * 6)
    return sys_, q0, q_ref


@functools.lru_cache(maxsize=1)
def _system():
    from netcosim.plants.flycrane.configurations import four_robot_nonsquare
    return four_robot_nonsquare()


@functools.lru_cache(maxsize=16)
def _offline_gain(T, q0_deg, qr_deg, d_reading, n_mu) -> tuple[float, float, float]:
    from .gain_design import design_nonsquare, estimate_mu
    cfg = FlyCraneNetworkConfig(T=T, q0_deg=q0_deg, qr_deg=qr_deg, d_reading=d_reading, n_mu=n_mu)
    sys_, q0, q_ref = setting(cfg)
    nrm = cfg.norm
    est = estimate_mu(sys_, q_ref, 1.05 * nrm(q0 - q_ref), n_samples=n_mu, kbar=np.ones(sys_.m), norm=nrm, seed=0)
    d = design_nonsquare(est.mu_hat, np.ones(sys_.m))
    return float(d.gain(T)), float(est.mu_hat), float(d.rho)


def offline_gain(config: FlyCraneNetworkConfig) -> float:
    """The offline gain (1/s): ``config.k_offline``, or ``tau_o_bar(mu_hat) / T`` designed
    as for Fig. 4.8 (``mu_hat`` (4.27) on the ball of radius 1.05 ``||q0 - q^r||_D``,
    ``n_mu`` samples, seed 0; (4.28)-(4.29) with the induced norm).  Cached per process."""
    if config.k_offline is not None:
        return float(config.k_offline)
    return _offline_gain(config.T, config.q0_deg, config.qr_deg, config.d_reading, config.n_mu)[0]


class GridRecorder(SolveIVP):
    """The plant integrator *base*, also reporting q (the first *m* states, rad and m)
    and the held u (m/s) every ``dt`` s from the solver's dense output (the steps are
    those of the plain integrator).  *base* is a :class:`~netcosim.plant.SolveIVP`
    (this recorder then integrates as it would) or a
    :class:`~netcosim.controllers.planner.plant_dop853.CompiledDOP853` (bound to the plant
    with this recorder's hooks).  Pass it as ``integrator=`` to
    :func:`~netcosim.controllers.planner.tasks.deploy`, call :meth:`start` with the built
    plant, read :meth:`arrays` after the run."""

    def __init__(self, base: Any, dt: float, m: int):
        if isinstance(base, CompiledDOP853):
            super().__init__("DOP853", base.rtol, base.atol, max_evaluations=base.max_evaluations)
        else:
            super().__init__(base.method, base.rtol, base.atol, base.max_step, base.max_evaluations)
        self.base = base
        self.dt, self.m = dt, m
        self.rows: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.plant: Any = None

    def bind(self, plant) -> Any:
        """This recorder for a SolveIVP base; the base's stepper, reporting here, for a CompiledDOP853."""
        if isinstance(self.base, CompiledDOP853):
            return self.base.bind(plant, hooks=self)
        return self

    def t_eval(self, t0, t1):
        dt = self.dt
        k0, k1 = math.floor(t0 / dt + 1e-9) + 1, math.floor(t1 / dt + 1e-9)
        return [k * dt for k in range(k0, k1 + 1) if k * dt < t1] + [t1]

    def observe(self, t, x) -> None:
        u = self.plant.u.copy()
        for tk, xk in zip(t, x.T):
            k = round(tk / self.dt)
            if abs(k * self.dt - tk) <= 1e-9:
                self.rows[k] = (xk[: self.m].copy(), u)

    def start(self, plant) -> None:
        """Record from the built *plant* (its instance), starting with its state and input now."""
        self.plant = plant
        self.rows[0] = (plant.x[: self.m].copy(), plant.u.copy())

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(t, q, u)`` on the ``dt`` grid: times (K,) [s], q (K, m) and the held u (K, n)."""
        ks = sorted(self.rows)
        t = np.array([k * self.dt for k in ks])
        q = np.array([self.rows[k][0] for k in ks]).reshape(len(ks), self.m)
        u = np.array([self.rows[k][1] for k in ks]).reshape(len(ks), -1)
        return t, q, u


def build(sim: Simulation, config: FlyCraneNetworkConfig, *, network: Any = None, exec_pivot: Any = None,
          exec_robot: Any = None) -> tuple[Deployment, Any]:
    """Wire the five nodes, the network and the plant of *config* inside *sim*.

    ``network``: the network (default: a :class:`~netcosim.network.WLAN80211b` named
    ``"wlan"`` with ``config``'s data rate, loss and retry limit).  ``exec_pivot``,
    ``exec_robot``: execution times (s) as :class:`~netcosim.controllers.planner.tasks.DeploymentConfig`
    takes them (a constant, a frozen distribution or ``fn(rng) -> s``) in place of
    ``config``'s constants (the HIL replay gives each job its measured response time).
    Returns ``(deployment, recorder)``; the recorder holds q and u every ``sample_dt`` s.
    """
    from netcosim.network import Bernoulli, WLAN80211b

    sys_, q0, q_ref = setting(config)
    if network is None:
        network = WLAN80211b(sim, "wlan", data_rate=config.data_rate, retry_limit=config.retry_limit + 1,
                             loss=Bernoulli(config.loss) if config.loss > 0 else None)
    if not config.schedules:
        for table in ("schedule", "jobs", "network_schedule", "signals"):
            sim.trace.configure(table, mode="off")
    online = config.strategy == "online"
    gain = OnlineGain() if online else OfflineGain(offline_gain(config))
    model = VelocityTrackingModel(config.alpha) if config.plant == "dynamic" else KinematicModel()
    dcfg = DeploymentConfig(
        config.T, PlannerLaw(gain, q_ref=q_ref, kbar=np.ones(sys_.m), norm=config.norm),
        architecture="centralized" if online else "sparse",
        exec_pivot=(config.exec_planner if online else config.exec_pose) if exec_pivot is None else exec_pivot,
        exec_robot=config.exec_robot if exec_robot is None else exec_robot,
        exec_watchdog=config.exec_watchdog, size_bits=config.size_bits, on_loss="zero" if online else "hold",
        watchdog_period=config.watchdog_period, plant=model, messaging=config.messaging, log_interval=None)
    recorder = GridRecorder(model.integrator(), config.sample_dt, sys_.m)
    dep = deploy(sim, sys_, q0, dcfg, network=network, integrator=recorder)
    recorder.start(dep.plant)
    return dep, recorder


def run(config: FlyCraneNetworkConfig | None = None, **changes) -> "FlyCraneRun":
    """Run *config* (default :class:`FlyCraneNetworkConfig`, with *changes*) for
    ``config.horizon`` s.  A run whose plant fails (singular configuration, non-finite
    state) is returned with ``failure`` set (the exception's type and message) and the
    series up to the last completed plant advance (one I/O instant to the next)."""
    config = config or FlyCraneNetworkConfig()
    if changes:
        config = config.replace(**changes)
    sim = Simulation(config.seed)
    dep, recorder = build(sim, config)
    failure = None
    try:
        sim.run(config.horizon)
    except Exception as exc:  # the plant left its domain: keep what was recorded
        failure = f"{type(exc).__name__}: {exc}"
    return FlyCraneRun.collect(config, sim, dep, recorder, failure)


@dataclass
class FlyCraneRun:
    """What one run recorded.

    ``config``; ``t`` (K,) s on the ``sample_dt`` grid; ``q`` (K, 10) rad and m;
    ``u`` (K, 12) desired robot velocities applied to the plant (m/s); ``q_ref`` (10,);
    ``norm_e`` (K,) ``||q - q^r||_2`` (unweighted, as Fig. 4.11 plots);
    ``samples``: one row per period (:class:`~netcosim.controllers.planner.deployment.PlannerResponse`
    as a DataFrame: h, t, k, q0.., u0..) as the tasks computed them; ``gains``: DataFrame
    ``t``, ``node``, ``k`` (1/s) of every command computed; ``schedule``, ``jobs``:
    the kernels' schedule and job tables; ``network_schedule``, ``frames``: the WLAN's;
    ``messages``: DataFrame per robot (``robot``, ``sent``, ``received``, ``loss``);
    ``failure``: None, or the error that stopped the plant; ``signals``: the trace's
    signals table (what the tasks logged, e.g. ``watchdog_zero`` when a watchdog zeroed a
    command; None if not collected).
    """

    config: FlyCraneNetworkConfig
    t: np.ndarray
    q: np.ndarray
    u: np.ndarray
    q_ref: np.ndarray
    samples: Any
    gains: Any
    schedule: Any
    jobs: Any
    network_schedule: Any
    frames: Any
    messages: Any
    failure: str | None = None
    signals: Any = None

    @property
    def norm_e(self) -> np.ndarray:
        """``||q(t) - q^r||_2`` on the grid ``t`` (rad and m mixed, as the thesis plots)."""
        return np.linalg.norm(self.q - self.q_ref, axis=1)

    @property
    def alpha(self) -> np.ndarray:
        """Cable angles ``alpha_i = q_i`` (K, 4), deg (Fig. A.2)."""
        return np.degrees(self.q[:, :4])

    @property
    def q_V(self) -> np.ndarray:
        """Load pose (K, 6): x, y, z (m), roll, pitch, yaw (deg) (Fig. A.3)."""
        return np.concatenate([self.q[:, 4:7], np.degrees(self.q[:, 7:10])], axis=1)

    @classmethod
    def collect(cls, config, sim, dep: Deployment, recorder: GridRecorder, failure) -> "FlyCraneRun":
        """The run of *config* (its :class:`FlyCraneNetworkConfig`) after *sim* ran: from the
        deployment *dep*, the *recorder* that sampled the plant and *failure* (None, or the
        error that stopped the plant)."""
        import pandas as pd

        from .deployment import CommandRecord, PlannerRecord
        t, q, u = recorder.arrays()
        _, _, q_ref = setting(config)
        gains = pd.DataFrame(
            [(r.t_done, r.node, r.k) for r in dep.records if isinstance(r, PlannerRecord)
             or (isinstance(r, CommandRecord) and not math.isnan(r.k))], columns=["t", "node", "k"])
        frames = sim.trace.frame("frames")
        sent = sum(1 for r in dep.records if not isinstance(r, CommandRecord))
        recv = {name: 0 for name in ROBOTS}
        for r in dep.records:
            if isinstance(r, CommandRecord):
                recv[r.node] += 1
        delivered = frames[frames["event"] == "delivered"]
        got = delivered.groupby(delivered["node"].astype(str)).size()
        messages = pd.DataFrame([(name, sent, int(got.get(name, 0)), recv[name]) for name in ROBOTS],
                                columns=["robot", "sent", "received", "processed"])
        messages["loss"] = 1.0 - messages["received"] / messages["sent"].where(messages["sent"] > 0)
        return cls(config, t, q, u, q_ref, dep.to_pandas(), gains, sim.trace.frame("schedule"),
                   sim.trace.frame("jobs"), sim.trace.frame("network_schedule"), frames, messages, failure,
                   sim.trace.frame("signals"))

    def to_pandas(self):
        """DataFrame on the grid: ``t``, ``norm_e``, ``q0..q9``, ``u0..u11``."""
        import pandas as pd
        cols = {"t": self.t, "norm_e": self.norm_e}
        cols.update({f"q{i}": self.q[:, i] for i in range(self.q.shape[1])})
        cols.update({f"u{i}": self.u[:, i] for i in range(self.u.shape[1])})
        return pd.DataFrame(cols)

    def plot(self, axes=None):
        """``||q - q^r||`` (log scale), the cable angles (deg) and u (m/s) against t (s);
        returns the three axes."""
        import matplotlib.pyplot as plt
        if axes is None:
            _, axes = plt.subplots(3, 1, sharex=True, figsize=(7, 7))
        ax_e, ax_a, ax_u = axes
        ax_e.semilogy(self.t, np.maximum(self.norm_e, 1e-16))
        ax_e.set_ylabel("||q - q^r||")
        ax_a.plot(self.t, self.alpha)
        ax_a.set_ylabel("alpha_i (deg)")
        ax_u.plot(self.t, self.u)
        ax_u.set_ylabel("u (m/s)")
        ax_u.set_xlabel("t (s)")
        ax_e.set_title(f"{self.config.strategy}, loss {self.config.loss:g}, {self.config.messaging}")
        return axes
