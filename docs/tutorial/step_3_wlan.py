"""
Step 3: the loop over an 802.11b link
=====================================

Now the sensor/actuator and the controller sit on two nodes that talk over an IEEE
802.11b WLAN (:class:`~netcosim.network.wlan.network.WLAN80211b`, 11 Mbit/s, DCF with
ACKs and retries).  :func:`~netcosim.controllers.networked_loop.networked_loop` adds the
three tasks of TrueTime's networked example: a periodic sampler on the sensor node
sends ``(t, y)`` to the controller; the controller's task is released by the message,
computes ``u`` and sends it back; the actuator task, released by that message, writes
``u`` and logs the sampling-to-actuation delay.

``message_loss=p`` drops each message with probability *p* before it reaches the air
(TrueTime's wireless loss); ``loss=p`` would be a *frame* loss, drawn per transmission
attempt and mostly repaired by the retries.
"""

# %%
from netcosim import ExactZOH, Simulation, WLAN80211b
from netcosim.controllers.networked_loop import networked_loop
from netcosim.controllers.pid import PID
from netcosim.plants.dc_servo import DCServo

PERIOD = 0.010      # sampling period (s)


def reference(t):
    """Square wave: +1 rad on the first half of each second, -1 rad on the second."""
    return 1.0 if (t % 1.0) < 0.5 else -1.0


def build(message_loss=0.0, seed=0):
    """The networked servo on a two-node 802.11b network; returns ``(sim, net)``."""
    sim = Simulation(seed=seed)
    servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=ExactZOH(), log_interval=1e-3)
    net = WLAN80211b(sim, "wlan", data_rate=11e6, message_loss=message_loss)
    sensor, controller = sim.node("sensor"), sim.node("controller")
    s_if = net.attach(sensor, position=(0.0, 0.0))          # positions in m
    c_if = net.attach(controller, position=(10.0, 0.0))
    networked_loop(servo, sensor, controller, s_if, c_if, law=PID(h=PERIOD).compute, reference=reference,
                   period=PERIOD, io_exec=0.0002, control_exec=0.0005, frame_bits=400)
    return sim, net


sim, net = build(message_loss=0.0)
sim.run(until=2.0)

# %%
# The sampling-to-actuation delay of every sample: two frames, each with its DIFS and
# ACK, plus the three jobs' execution times -- the same for every sample here, as nothing
# else is on the air.
delay = sim.trace.signal("sensor.actuate", "delay")
print(f"delay: mean {delay.mean() * 1e3:.3f} ms, max {delay.max() * 1e3:.3f} ms over {len(delay)} samples")
print(net.stats["total"])

# %%
# The response over the network, without loss.
import matplotlib.pyplot as plt  # noqa: E402

fig, ax = plt.subplots(figsize=(6, 3))
y = sim.trace.signal("servo", "y.y")
ax.plot(y.index, y.to_numpy(), label="y (rad)")
r = sim.trace.signal("controller.pid", "r")
ax.step(r.index, r.to_numpy(), where="post", label="r (rad)")
ax.set_xlabel("time (s)")
ax.legend()
ax.set_title("servo over 802.11b, no loss")
fig.tight_layout()
