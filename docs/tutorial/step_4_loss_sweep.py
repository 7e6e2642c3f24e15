"""
Step 4: a loss sweep over seeds
===============================

One lossy run is one draw of the losses.  :func:`~netcosim.sweep.runner.run_sweep` runs a
*scenario* ``fn(params, seed) -> dict`` for every case of a grid and every seed, and
returns a table with one row per run (its parameters, seed, status and the scalars the
scenario returned).  Each run's seed is derived from the root seed, the case and the
seed index, so a run can be reproduced on its own and the sweep gives the same numbers
on any machine and with any number of workers.

The scenario builds step 3's loop with a message loss *p*, runs 2 s and scores it by
the quadratic cost ``J = ∫ (e² + 0.01 u²) dt`` (e = r - y in rad, u in V), with
:func:`netcosim.metrics.quadratic_cost`.
"""

# %%
import numpy as np

from netcosim import ExactZOH, Simulation, WLAN80211b, metrics
from netcosim.controllers.networked_loop import networked_loop
from netcosim.controllers.pid import PID
from netcosim.plants.dc_servo import DCServo
from netcosim.sweep import run_sweep

PERIOD = 0.010      # sampling period (s)
DURATION = 2.0      # simulated time per run (s)


def reference(t):
    """Square wave: +1 rad on the first half of each second, -1 rad on the second."""
    return 1.0 if (t % 1.0) < 0.5 else -1.0


def build(message_loss=0.0, seed=0):
    """The networked servo of step 3; returns ``(sim, net)``."""
    sim = Simulation(seed=seed)
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=ExactZOH(), log_interval=1e-3)
    net = WLAN80211b(sim, "wlan", data_rate=11e6, message_loss=message_loss)
    sensor, controller = sim.node("sensor"), sim.node("controller")
    s_if = net.attach(sensor, position=(0.0, 0.0))
    c_if = net.attach(controller, position=(10.0, 0.0))
    networked_loop(servo, sensor, controller, s_if, c_if, law=PID(h=PERIOD).compute, reference=reference,
                   period=PERIOD, io_exec=0.0002, control_exec=0.0005, frame_bits=400)
    return sim, net


def scenario(params, seed):
    """One run: ``params = {"loss": p}``; returns J, the measured message loss and a divergence flag."""
    sim, net = build(message_loss=params["loss"], seed=seed)
    sim.run(until=DURATION)
    y = sim.trace.signal("servo", "y.y")
    t = y.index.to_numpy()
    e = np.array([reference(x) for x in t]) - y.to_numpy()
    u = sim.trace.signal("sensor.actuate", "u")                  # held between actuations
    u_on_t = u.reindex(t, method="ffill").fillna(0.0).to_numpy()
    return {"J": metrics.quadratic_cost(t, e, u_on_t, Q=1.0, R=0.01),
            "message_loss": net.stats["total"]["message_loss"],
            "diverged": metrics.diverged(y.to_numpy(), 10.0)}          # |y| > 10 rad


# %%
# Seven loss probabilities, five seeds each: 35 runs of 2 s, in this process
# (``executor="pool"``, the default, would spread them over the cores; it needs the
# scenario importable by name, ``"my_study:scenario"``).
result = run_sweep(scenario, grid={"loss": [0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3]}, seeds=5, executor="serial",
                   quiet=True)
runs = result.to_pandas()
print(runs[["loss", "seed", "status", "J", "message_loss"]].head(8))

# %%
# The cost against loss: the median over seeds with its quartile band
# (:func:`netcosim.sweep.aggregate.plot_sweep`).  A lost measurement or command leaves the
# actuator holding its last value for another period; the cost grows with *p* and so
# does its spread across seeds.  Around p = 0.3 the loop starts to diverge (``n_diverged``:
# such runs are counted, not plotted): the PID, tuned for a 10 ms loop without loss, runs
# on stale information too often.
from netcosim.sweep.aggregate import plot_sweep, summarize  # noqa: E402

print(summarize(runs, "loss", "J"))
ax = plot_sweep(runs, x="loss", y="J", hue=None)
ax.set_xlabel("message loss probability p")
ax.set_ylabel("J")
ax.set_title("servo over 802.11b: J against message loss, 5 seeds")
ax.figure.tight_layout()
