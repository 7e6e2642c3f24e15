"""Controllers of the reference applications, imported as ``netcosim.controllers``.

* :mod:`netcosim.controllers.pid` — TrueTime's discrete PID (``pidcode``);
* :mod:`netcosim.controllers.networked_loop` — TrueTime's networked control loop as task
  factories (sensor, controller, actuator nodes);
* :mod:`netcosim.controllers.aodv` — AODV routing as application tasks (TrueTime's
  ``examples/AODV``);
* :mod:`netcosim.controllers.nmpc` — real-time-iteration nonlinear MPC (CasADi);
* :mod:`netcosim.controllers.landing` — the tethered-UAV landing of thesis ch. 2;
* :mod:`netcosim.controllers.planner` — the kinematic local planners of thesis ch. 3-5.
"""
