"""Former module of the kinematic local planners (thesis ch. 3 and 4); they live in the
package :mod:`controllers.planner` (laws, flow, DOP853 stepper, norms, structure) and the
kinematic model in :mod:`plants.kinematic`, the CasADi compile cache in
:mod:`plants.casadi_tools`.  Kept as an import path: every public name is re-exported,
and so are the former private helpers under their old names.  Setting
``local_planner.COMPILE_FLOW`` sets :data:`plants.casadi_tools.COMPILE`.
"""

from __future__ import annotations

import sys
import types

import plants.casadi_tools as _casadi_tools
from plants.casadi_tools import CompiledCodeWarning, cache_dir
from plants.casadi_tools import compile_functions as _compile
from plants.kinematic import KinematicSystem

from .planner import flow as _flow_module
from .planner.dop853 import EVENT_XTOL, DenseFlow
from .planner.dop853 import integrate_until_return as _dop853
from .planner.dop853 import root_increasing as _root_increasing
from .planner.flow import (FLOW_ATOL_REL, FLOW_RTOL, PIVOT_RTOL, TAU_XTOL, AuxiliaryFlow, _casadi_flow_functions,
                           _compiled_flow, _CompiledFlow, _FallBack, _FlowNorm, _regular_along, _SVDFlow,
                           online_gain, solve_auxiliary_flow)
from .planner.kinematics import (RANK_RTOL, SingularConfigurationError, check_gain_matrix, check_period,
                                 check_system, configuration_rate, integrate_kinematics, project)
from .planner.kinematics import as_vector as _vec
from .planner.kinematics import diag_gain as _diag_gain
from .planner.kinematics import jacobian as _jacobian
from .planner.kinematics import pinv_solve as _pinv_apply
from .planner.laws import (OfflineGain, OnlineGain, planner_velocity, robot_velocity, sampled_velocity,
                           simulate_sampled)
from .planner.norms import WeightedNorm
from .planner.structure import StarStructure

__all__ = [
    "SingularConfigurationError", "StarStructure", "WeightedNorm", "check_system",
    "check_gain_matrix", "check_period", "planner_velocity", "robot_velocity",
    "configuration_rate", "project", "AuxiliaryFlow", "DenseFlow", "solve_auxiliary_flow",
    "online_gain", "OfflineGain", "OnlineGain", "sampled_velocity", "simulate_sampled", "integrate_kinematics",
    "CompiledCodeWarning", "cache_dir", "KinematicSystem", "RANK_RTOL", "FLOW_RTOL", "FLOW_ATOL_REL", "TAU_XTOL",
    "PIVOT_RTOL", "EVENT_XTOL",
]

_PRIVATE = (_compile, _dop853, _root_increasing, _flow_module, _casadi_flow_functions, _compiled_flow, _CompiledFlow,
            _FallBack, _FlowNorm, _regular_along, _SVDFlow, _vec, _diag_gain, _jacobian, _pinv_apply)

#: Module state that moved: old name -> (module, name).  Reading and assigning the old
#: name (``local_planner.COMPILE_FLOW = False``, ``monkeypatch.setattr``) reach the new one.
_MOVED = {"COMPILE_FLOW": (_casadi_tools, "COMPILE"), "_warned_fallback": (_casadi_tools, "_warned"),
          "_COMPILED_FLOWS": (_flow_module, "_COMPILED_FLOWS"), "_BY_SOURCE": (_flow_module, "_BY_SOURCE")}


def _forward(mod, attr):
    return property(lambda self: getattr(mod, attr), lambda self, value: setattr(mod, attr, value),
                    doc=f"Alias of ``{mod.__name__}.{attr}``.")


# properties (data descriptors) on the module's class, so reads, assignments and
# monkeypatch's undo all reach the new home of the name
_ForwardingModule = type("_ForwardingModule", (types.ModuleType,),
                         {name: _forward(mod, attr) for name, (mod, attr) in _MOVED.items()})
sys.modules[__name__].__class__ = _ForwardingModule
