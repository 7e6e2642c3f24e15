"""netcosim: networked-control co-simulation on SimPy.

Real-time kernels run controller tasks on nodes, nodes talk over simulated networks,
and continuous plants are integrated lazily alongside.  Time is in seconds at the API
(integer picoseconds inside, see :mod:`netcosim.timebase`).
"""

from .continuous import RK4, ContinuousSystem, HybridEvent, PlantInstance, SolveIVP
from .errors import NotConnectedError
from .network import (BROADCAST, CAN, CSMACD, FDMA, TDMA, Bernoulli, GilbertElliott, IdealLink,
                      IEEE802154, RoundRobin, SwitchedEthernet, TraceLoss, WLAN80211b)
from .kernel import (EDF, ConditionVariable, DeadlineMonotonic, Event, FixedPriority, Mailbox, Monitor, RateMonotonic,
                     SchedulingPolicy, Semaphore)
from .sim import Simulation
from .timebase import RESOLUTION

__all__ = ["BROADCAST", "Bernoulli", "CAN", "CSMACD", "FDMA", "GilbertElliott", "IEEE802154", "IdealLink",
           "RoundRobin", "SwitchedEthernet", "TDMA", "TraceLoss", "WLAN80211b",
           "ConditionVariable", "ContinuousSystem", "DeadlineMonotonic", "EDF", "Event", "FixedPriority", "HybridEvent",
           "Mailbox", "Monitor", "NotConnectedError", "PlantInstance", "RESOLUTION", "RK4",
           "RateMonotonic", "SchedulingPolicy", "Semaphore", "Simulation", "SolveIVP"]

__version__ = "0.1.0"
