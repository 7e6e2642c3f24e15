"""netcosim: networked-control co-simulation on SimPy.

Real-time kernels run controller tasks on nodes, nodes talk over simulated networks,
and continuous plants are integrated lazily alongside.  Time is in seconds at the API
(integer picoseconds inside, see :mod:`netcosim.timebase`).

Contents of the package namespace (``__all__`` lists exactly these names, the keys of
``_API``; a test checks it):

Simulation
    :class:`Simulation`, :data:`RESOLUTION` (the time step, s)

Kernel: scheduling policies
    :class:`SchedulingPolicy`, :class:`FixedPriority`, :class:`RateMonotonic`,
    :class:`DeadlineMonotonic`, :class:`EDF`

Kernel: synchronisation
    :class:`Mailbox`, :class:`Semaphore`, :class:`Monitor`, :class:`ConditionVariable`

Kernel: a node's local clock
    :class:`LocalClock` (offset, drift, steps and slews; ``sim.node(..., clock=...)``)

Energy
    :class:`ConstantPower`, :class:`DvsPower` (CPU power models: ``node.set_power_model``),
    :class:`RadioPower` (``network.set_energy_model``), :class:`Battery` (``node.set_battery``),
    :class:`BatteryEmptyWarning`

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
    :class:`NotConnectedError`, :class:`SimulationFailedError`, :class:`UnyieldedExecuteError`,
    :class:`IntegrationError`
"""

from typing import TYPE_CHECKING

from .lazy import lazy_exports

#: The public API, the one place it is spelled: name -> the submodule that defines it.
#: ``__all__`` (in this order), the lazy imports (PEP 562: a name is imported on first use,
#: so that importing a light submodule such as netcosim.transport.client does not load
#: SimPy, NumPy or CasADi) and ``dir(netcosim)`` come from it; the ``TYPE_CHECKING``
#: imports below are generated from it for type checkers (tests/test_package_toc.py
#: checks that they match, and shows the text to paste when they do not).
_API = {
    # Simulation
    "Simulation": "sim", "RESOLUTION": "timebase",
    # kernel: scheduling policies
    "SchedulingPolicy": "kernel", "FixedPriority": "kernel", "RateMonotonic": "kernel", "DeadlineMonotonic": "kernel",
    "EDF": "kernel",
    # kernel: synchronisation
    "Mailbox": "kernel", "Semaphore": "kernel", "Monitor": "kernel", "ConditionVariable": "kernel",
    # kernel: a node's local clock
    "LocalClock": "kernel",
    # energy
    "ConstantPower": "energy", "DvsPower": "energy", "RadioPower": "energy", "Battery": "energy",
    "BatteryEmptyWarning": "errors",
    # networks
    "IdealLink": "network", "FDMA": "network", "CSMACD": "network", "CAN": "network", "RoundRobin": "network",
    "TDMA": "network", "SwitchedEthernet": "network", "WLAN80211b": "network", "IEEE802154": "network",
    "BROADCAST": "network",
    # network loss models
    "Bernoulli": "network", "GilbertElliott": "network", "TraceLoss": "network",
    # plants
    "ContinuousSystem": "plant", "PlantInstance": "plant", "HybridEvent": "plant",
    "RK4": "plant", "SolveIVP": "plant", "ExactZOH": "plant",
    # CPU time of controller code
    "CPUTimeModel": "cputime", "FixedCPUTime": "cputime", "RecordedCPUTime": "cputime", "WallClockCPUTime": "cputime",
    "NonReproducibleWarning": "cputime",
    # errors
    "NetcosimError": "errors", "ConfigurationError": "errors", "ConfigurationTypeError": "errors",
    "NotConnectedError": "errors", "SimulationFailedError": "errors", "UnyieldedExecuteError": "errors",
    "IntegrationError": "errors",
}

if TYPE_CHECKING:
    from .cputime import CPUTimeModel, FixedCPUTime, NonReproducibleWarning, RecordedCPUTime, WallClockCPUTime
    from .energy import Battery, ConstantPower, DvsPower, RadioPower
    from .errors import (
        BatteryEmptyWarning,
        ConfigurationError,
        ConfigurationTypeError,
        IntegrationError,
        NetcosimError,
        NotConnectedError,
        SimulationFailedError,
        UnyieldedExecuteError,
    )
    from .kernel import (
        EDF,
        ConditionVariable,
        DeadlineMonotonic,
        FixedPriority,
        LocalClock,
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
    from .plant import RK4, ContinuousSystem, ExactZOH, HybridEvent, PlantInstance, SolveIVP
    from .sim import Simulation
    from .timebase import RESOLUTION

__all__ = list(_API)
__version__ = "0.1.0"

__getattr__, __dir__ = lazy_exports(__name__, _API, __all__)
