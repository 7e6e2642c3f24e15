"""FMUs (the Functional Mock-up Interface, FMI 2.0 and 3.0) as netcosim plants.

* :class:`ModelExchangeFMU` (:mod:`~netcosim.fmi.model_exchange`): a model-exchange FMU
  as a continuous plant integrated by the project's integrators;
* :class:`CoSimulationFMU` (:mod:`~netcosim.fmi.cosimulation`): a co-simulation FMU as a
  plant stepped by ``doStep`` to the exact instants the simulation needs;
* :class:`ScheduledExecutionFMU` (:mod:`~netcosim.fmi.scheduled`): an FMI 3 Scheduled
  Execution FMU's clocked partitions as periodic kernel tasks on a node;
* :func:`~netcosim.fmi.export.export_network_fmu` (:mod:`~netcosim.fmi.export`, needs
  pythonfmu): a network as an FMI 2.0 co-simulation FMU (``netcosim export-fmu``);
* :mod:`~netcosim.fmi.description`: reading an FMU, its variables and units, clear errors.

FMPy does the loading (``pip install 'netcosim[fmi]'``); it is imported when an FMU is
opened, not when this package is.  See ``docs/fmi.md``.
"""

from .cosimulation import MIN_RETRY_STEP, CoSimulationFMU, DoStepper
from .description import FMUFile, Variable
from .model_exchange import MAX_EVENT_ITERATIONS, ModelExchangeFMU
from .scheduled import ScheduledExecutionFMU

__all__ = ["ModelExchangeFMU", "CoSimulationFMU", "ScheduledExecutionFMU", "DoStepper", "FMUFile", "Variable",
           "MAX_EVENT_ITERATIONS", "MIN_RETRY_STEP"]
