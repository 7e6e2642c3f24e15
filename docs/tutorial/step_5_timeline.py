"""
Step 5: the timeline of one lossy run
=====================================

Why does the cost grow?  The timeline of one run with 30 % message loss shows it: the
network schedule (each node's radio: idle, sending, receiving), the lost messages, the
actuator's jobs that never came, and the angle drifting from the reference while the
last command is held.
"""

# %%
import matplotlib.pyplot as plt

from netcosim import ExactZOH, Simulation, WLAN80211b
from netcosim.controllers.networked_loop import networked_loop
from netcosim.controllers.pid import PID
from netcosim.plants.dc_servo import DCServo

PERIOD = 0.010      # sampling period (s)


def reference(t):
    """Square wave: +1 rad on the first half of each second, -1 rad on the second."""
    return 1.0 if (t % 1.0) < 0.5 else -1.0


sim = Simulation(seed=3)
servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=ExactZOH(), log_interval=1e-3)
net = WLAN80211b(sim, "wlan", data_rate=11e6, message_loss=0.3)
sensor, controller = sim.node("sensor"), sim.node("controller")
s_if = net.attach(sensor, position=(0.0, 0.0))
c_if = net.attach(controller, position=(10.0, 0.0))
networked_loop(servo, sensor, controller, s_if, c_if, law=PID(h=PERIOD).compute, reference=reference,
               period=PERIOD, io_exec=0.0002, control_exec=0.0005, frame_bits=400)
sim.run(until=1.0)
print(net.stats["total"])

# %%
# Three panels on one time axis, the first 100 ms after the reference steps up.
t0, t1 = 0.0, 0.1
fig, (a1, a2, a3) = plt.subplots(3, 1, figsize=(7, 7), sharex=True)
sim.trace.plot("schedule", t_range=(t0, t1), ax=a1, title="tasks (high: running)")
sim.trace.plot("network", t_range=(t0, t1), ax=a2, title="802.11b: radios and lost messages")
y = sim.trace.signal("servo", "y.y")
u = sim.trace.signal("sensor.actuate", "u")
window = (y.index >= t0) & (y.index <= t1)
a3.plot(y.index[window], y.to_numpy()[window], label="y (rad)")
a3.step(u.index, u.to_numpy() / 10.0, where="post", label="u / 10 (V)")
a3.set_xlim(t0, t1)
a3.set_xlabel("time (s)")
a3.legend(loc="lower right")
a3.set_title("angle and held command")
fig.tight_layout()

# %%
# The same run in the browser: :meth:`~netcosim.trace.Trace.view` writes one self-contained
# HTML file (it opens offline) with the tasks, the frames by outcome and the signals on
# linked time axes.  Drag to pan, use the wheel to zoom; hover over a job or a frame for
# its details.  The page below is the file this step wrote.
page = sim.trace.view("timeline.html", signals=["servo.y.y", "sensor.actuate.u"])
print(page.name, f"{page.stat().st_size / 1e6:.1f} MB")
