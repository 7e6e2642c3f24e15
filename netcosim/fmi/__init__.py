"""FMUs (the Functional Mock-up Interface, FMI 2.0 and 3.0) as netcosim plants.

* :class:`ModelExchangeFMU` (:mod:`~netcosim.fmi.model_exchange`): a model-exchange FMU
  as a continuous plant integrated by the project's integrators;
* :class:`CoSimulationFMU` (:mod:`~netcosim.fmi.cosimulation`): a co-simulation FMU as a
  plant stepped by ``doStep`` to the exact instants the simulation needs;
* :mod:`~netcosim.fmi.description`: reading an FMU, its variables and units, clear errors.

FMPy does the loading (``pip install 'netcosim[fmi]'``); it is imported when an FMU is
opened, not when this package is.  See ``docs/fmi.md``.
"""

from .cosimulation import MIN_RETRY_STEP, CoSimulationFMU, DoStepper
from .description import FMUFile, Variable
from .model_exchange import MAX_EVENT_ITERATIONS, ModelExchangeFMU

__all__ = ["ModelExchangeFMU", "CoSimulationFMU", "DoStepper", "FMUFile", "Variable", "MAX_EVENT_ITERATIONS",
           "MIN_RETRY_STEP"]
