"""
Step 2: a controller task on a real-time kernel
===============================================

A node is a CPU with a scheduler (fixed priority, deadline monotonic, EDF, ...).  A task
is a generator function ``body(ctx)``: it reads plant outputs, computes, and consumes CPU
time only through ``yield ctx.execute(seconds)``, which the kernel schedules (preemption,
context switches).  So the delay between sampling and actuation *emerges* from the
schedule, as in TrueTime.

This is TrueTime's servo example: TrueTime's PID (:class:`~netcosim.controllers.pid.PID`)
every 6 ms with 2 ms of computation between the read and the write.
"""

# %%
from netcosim import ExactZOH, Simulation
from netcosim.controllers.pid import PID
from netcosim.plants.dc_servo import DCServo

sim = Simulation(seed=1)
servo = sim.plant(DCServo(), x0=[0.0, 0.0], name="servo", integrator=ExactZOH(), log_interval=1e-3)
cpu = sim.node("controller", scheduler="fixed_priority", context_switch=20e-6)
pid = PID(h=0.006)


def reference(t):
    """Square wave: +1 rad on the first half of each second, -1 rad on the second."""
    return 1.0 if (t % 1.0) < 0.5 else -1.0


@cpu.periodic(period=0.006, priority=1)
def control(ctx):
    r = reference(ctx.now)
    y = ctx.read(servo.output("y"))       # sampled when the job starts
    u = pid.compute(r, y)
    yield ctx.execute(0.002)              # 2 ms of CPU, preemptible
    ctx.write(servo.input("u"), u)        # applied at the end of the segment (ZOH)
    ctx.log("r", r)


sim.run(until=1.0)

# %%
# The response: the angle follows the square wave.
import matplotlib.pyplot as plt  # noqa: E402

fig, ax = plt.subplots(figsize=(6, 3))
y = sim.trace.signal("servo", "y.y")
r = sim.trace.signal("controller.control", "r")
ax.plot(y.index, y.to_numpy(), label="y (rad)")
ax.step(r.index, r.to_numpy(), where="post", label="r (rad)")
ax.set_xlabel("time (s)")
ax.legend()
ax.set_title("PID task, h = 6 ms, 2 ms computation")
fig.tight_layout()

# %%
# The jobs table: one row per job, times in seconds.  The response time is the 2 ms of
# computation plus the context switch.
jobs = sim.trace.to_pandas("jobs")
print(jobs[["task", "release", "start", "finish", "response_time"]].head())
print(f"response time: {jobs['response_time'].min() * 1e3:.3f} ms to {jobs['response_time'].max() * 1e3:.3f} ms")

# %%
# The kernel's timeline over the first 30 ms: TrueTime's staircase (high while running).
fig, ax = plt.subplots(figsize=(7, 2.5))
sim.trace.plot("schedule", t_range=(0, 0.03), ax=ax, title="schedule of the controller node")
fig.tight_layout()
