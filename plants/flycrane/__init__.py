"""The Fly-crane family: cable-suspended platforms carried by robots (thesis ch. 3-5, B.1).

* :mod:`.attachments` — how one robot hangs from the platform (two cables, one cable,
  planar formation agent);
* :mod:`.kinematics` — :class:`MultiRobotSystem`: h(q), A_q, pseudo-inverse, projector,
  singularity measure;
* :mod:`.configurations` — ready-made systems (thesis Fly-crane, 4-robot non-square,
  square family, 2-D formation);
* :mod:`.dynamics` — Lagrangian model M(q), C(q, q̇)q̇, g(q), cable tensions;
* :mod:`.input_modes` — netcosim plants (kinematic velocity input, velocity tracking
  with gravity compensation, raw forces);
* :mod:`.cable_break` — a cable that breaks: the post-break system, the hybrid reset,
  its dynamics and the platform statics (beyond the thesis, §6.3);
* :mod:`.collisions` — closest robot–robot approach along a motion, between samples.
"""

from . import configurations
from .attachments import GeometryError, OneCable, PlanarAgent, TwoCable
from .input_modes import ForcePlant, KinematicPlant, VelocityTrackingPlant
from .kinematics import (
                         ConfigurationDomainError,
                         MassProperties,
                         MultiRobotSystem,
                         SingularConfigurationError,
                         plate_inertia,
)

__all__ = ["configurations", "GeometryError", "OneCable", "PlanarAgent", "TwoCable",
           "ConfigurationDomainError", "MassProperties", "MultiRobotSystem", "SingularConfigurationError",
           "plate_inertia", "KinematicPlant", "VelocityTrackingPlant", "ForcePlant"]
