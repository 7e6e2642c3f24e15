"""
Step 1: a plant
===============

A plant is a :class:`~netcosim.plant.system.ContinuousSystem` (``dx/dt = f(t, x, u)``,
``y = g(t, x, u)``) that a :class:`~netcosim.sim.Simulation` integrates alongside the
discrete events.  Nothing but a task changes its input, and it is advanced only when
something reads it (or logs it), so a plant costs nothing between events.

The DC servo of TrueTime's examples is linear, so :class:`~netcosim.plant.exact_zoh.ExactZOH`
advances it by the exact zero-order-hold transition (no step size to choose).
"""

# %%
# The model: two states (angle in rad, angular velocity in rad/s), one input (V).
from netcosim import ExactZOH, Simulation
from netcosim.plants.dc_servo import DCServo

servo_model = DCServo()            # k = 1000 rad/(V s^2), a = 1 1/s
print("A =", servo_model.A.tolist(), " B =", servo_model.B.ravel().tolist())

# %%
# A simulation holds the plant; ``log_interval`` (s) samples its output into the trace.
# A node with one task applies a 1 ms pulse of 1 V at t = 0 (a task is the only way in:
# step 2 is about tasks), and we run 0.2 s.
sim = Simulation(seed=0)
servo = sim.plant(servo_model, x0=[0.0, 0.0], name="servo", integrator=ExactZOH(), log_interval=1e-3)
node = sim.node("driver")


@node.periodic(period=1.0, priority=1, name="pulse")
def pulse(ctx):
    ctx.write(servo.input("u"), 1.0)      # applied now, held (zero-order hold)
    yield ctx.sleep(0.001)                # 1 ms later ...
    ctx.write(servo.input("u"), 0.0)      # ... back to 0 V


sim.run(until=0.2)

# %%
# The angle after a 1 V, 1 ms pulse: the velocity jumps to about 1 rad/s and decays
# with the pole at -1 1/s, so the angle ramps at about 1 rad/s.
y = sim.trace.signal("servo", "y.y")       # a pandas Series indexed by time (s)
print(f"angle at 0.2 s: {y.iloc[-1]:.4f} rad")
ax = y.plot(drawstyle="default")
ax.set_xlabel("time (s)")
ax.set_ylabel("angle y (rad)")
ax.set_title("DC servo after a 1 V, 1 ms pulse")
