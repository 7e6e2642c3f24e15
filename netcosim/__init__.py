"""netcosim: networked-control co-simulation on SimPy.

Real-time kernels run controller tasks on nodes, nodes talk over simulated networks,
and continuous plants are integrated lazily alongside.  Time is in seconds at the API
(integer picoseconds inside, see :mod:`netcosim.timebase`).

Contents of the package namespace (``__all__`` lists exactly these names; a test checks it):

Simulation
    :class:`Simulation`, :data:`RESOLUTION` (the time step, s)

Kernel: scheduling policies
    :class:`SchedulingPolicy`, :class:`FixedPriority`, :class:`RateMonotonic`,
    :class:`DeadlineMonotonic`, :class:`EDF`

Kernel: synchronisation
    :class:`Mailbox`, :class:`Semaphore`, :class:`Monitor`, :class:`ConditionVariable`,
    :class:`Event` (older name of :class:`ConditionVariable`)

Networks
    :class:`IdealLink`, :class:`FDMA`, :class:`CSMACD`, :class:`CAN`, :class:`RoundRobin`,
    :class:`TDMA`, :class:`SwitchedEthernet`, :class:`WLAN80211b`, :class:`IEEE802154`,
    :data:`BROADCAST` (destination of a broadcast frame)

Network loss models
    :class:`Bernoulli`, :class:`GilbertElliott`, :class:`TraceLoss`

Plants
    :class:`ContinuousSystem`, :class:`PlantInstance`, :class:`HybridEvent`, :class:`RK4`,
    :class:`SolveIVP`, :class:`ExactZOH`

CPU time of controller code
    :class:`CPUTimeModel`, :class:`FixedCPUTime`, :class:`RecordedCPUTime`,
    :class:`WallClockCPUTime`, :class:`NonReproducibleWarning`

Errors
    :class:`NetcosimError`, :class:`ConfigurationError`, :class:`ConfigurationTypeError`,
    :class:`NotConnectedError`, :class:`SingularConfigurationError`,
    :class:`SimulationFailedError`, :class:`UnyieldedExecuteError`, :class:`IntegrationError`
"""

from typing import TYPE_CHECKING

from .lazy import lazy_exports

if TYPE_CHECKING:
    from .continuous import RK4, ContinuousSystem, ExactZOH, HybridEvent, PlantInstance, SolveIVP
    from .cputime import CPUTimeModel, FixedCPUTime, NonReproducibleWarning, RecordedCPUTime, WallClockCPUTime
    from .errors import (
        ConfigurationError,
        ConfigurationTypeError,
        IntegrationError,
        NetcosimError,
        NotConnectedError,
        SimulationFailedError,
        SingularConfigurationError,
        UnyieldedExecuteError,
    )
    from .kernel import (
        EDF,
        ConditionVariable,
        DeadlineMonotonic,
        Event,
        FixedPriority,
        Mailbox,
        Monitor,
        RateMonotonic,
        SchedulingPolicy,
        Semaphore,
    )
    from .network import (
        BROADCAST,
        CAN,
        CSMACD,
        FDMA,
        IEEE802154,
        TDMA,
        Bernoulli,
        GilbertElliott,
        IdealLink,
        RoundRobin,
        SwitchedEthernet,
        TraceLoss,
        WLAN80211b,
    )
    from .sim import Simulation
    from .timebase import RESOLUTION

# Names are imported on first use (PEP 562), so that importing a light submodule such as
# netcosim.transport.client does not load SimPy, NumPy or CasADi.
_LAZY = {
    "RK4": "continuous",
    "ContinuousSystem": "continuous",
    "ExactZOH": "continuous",
    "HybridEvent": "continuous",
    "PlantInstance": "continuous",
    "SolveIVP": "continuous",
    "CPUTimeModel": "cputime",
    "FixedCPUTime": "cputime",
    "NonReproducibleWarning": "cputime",
    "RecordedCPUTime": "cputime",
    "WallClockCPUTime": "cputime",
    "ConfigurationError": "errors",
    "ConfigurationTypeError": "errors",
    "IntegrationError": "errors",
    "NetcosimError": "errors",
    "NotConnectedError": "errors",
    "SimulationFailedError": "errors",
    "SingularConfigurationError": "errors",
    "UnyieldedExecuteError": "errors",
    "EDF": "kernel",
    "ConditionVariable": "kernel",
    "DeadlineMonotonic": "kernel",
    "Event": "kernel",
    "FixedPriority": "kernel",
    "Mailbox": "kernel",
    "Monitor": "kernel",
    "RateMonotonic": "kernel",
    "SchedulingPolicy": "kernel",
    "Semaphore": "kernel",
    "BROADCAST": "network",
    "CAN": "network",
    "CSMACD": "network",
    "FDMA": "network",
    "IEEE802154": "network",
    "TDMA": "network",
    "Bernoulli": "network",
    "GilbertElliott": "network",
    "IdealLink": "network",
    "RoundRobin": "network",
    "SwitchedEthernet": "network",
    "TraceLoss": "network",
    "WLAN80211b": "network",
    "Simulation": "sim",
    "RESOLUTION": "timebase",
}

__all__ = [
    # simulation
    "Simulation", "RESOLUTION",
    # kernel: scheduling policies
    "SchedulingPolicy", "FixedPriority", "RateMonotonic", "DeadlineMonotonic", "EDF",
    # kernel: synchronisation
    "Mailbox", "Semaphore", "Monitor", "ConditionVariable", "Event",
    # networks
    "IdealLink", "FDMA", "CSMACD", "CAN", "RoundRobin", "TDMA", "SwitchedEthernet", "WLAN80211b", "IEEE802154",
    "BROADCAST",
    # network loss models
    "Bernoulli", "GilbertElliott", "TraceLoss",
    # plants
    "ContinuousSystem", "PlantInstance", "HybridEvent", "RK4", "SolveIVP", "ExactZOH",
    # CPU time of controller code
    "CPUTimeModel", "FixedCPUTime", "RecordedCPUTime", "WallClockCPUTime", "NonReproducibleWarning",
    # errors
    "NetcosimError", "ConfigurationError", "ConfigurationTypeError", "NotConnectedError",
    "SingularConfigurationError", "SimulationFailedError", "UnyieldedExecuteError", "IntegrationError",
]

__version__ = "0.1.0"


__getattr__, __dir__ = lazy_exports(__name__, _LAZY, __all__)
