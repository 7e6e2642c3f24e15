"""Invalid inputs to continuous plants: construction, x0, integrators, ports, logging,
writes, disturbances, events and python-control conversions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from invalid_cases import Case
from netcosim import RK4, ContinuousSystem, HybridEvent, Simulation, SolveIVP
from netcosim.errors import ConfigurationError, ConfigurationTypeError, IntegrationError
from netcosim.plants.dc_servo import DCServo


def _servo(**kw):
    return Simulation().plant(DCServo(), x0=[0.0, 0.0], name="s", **kw)


def _plant(system, x0, **kw):
    return Simulation().plant(system, x0=x0, name="p", log="none", **kw)


def _disturbed(d):
    """x' = -x + d0 with one disturbance input, advanced 0.1 s."""
    sys = ContinuousSystem(f=lambda t, x, u, p: -x + u[0], states=1, disturbances=1)
    _plant(sys, [0.0], disturbance=d, integrator=RK4(dt=0.01)).advance(0.1)


def _nan_output_read():
    sys = ContinuousSystem(f=lambda t, x, u, p: np.zeros(1), h=lambda t, x, u, p: np.array([math.nan]),
                           states=1, outputs=["level"])
    _plant(sys, [0.0]).output("level").read()


def _rk4_absurd_advance():
    sys = ContinuousSystem(f=lambda t, x, u, p: -x, states=1)
    _plant(sys, [1.0], integrator=RK4(dt=1e-12)).advance(1e-3)


def _solve_ivp_budget():
    sys = ContinuousSystem(f=lambda t, x, u, p: -1e9 * x, states=1)
    _plant(sys, [1.0], integrator=SolveIVP(max_evaluations=200)).advance(1e-3)


def _control():
    return pytest.importorskip("control")


def _pc_servo(**kw):
    return _control().ss([[0.0, 1.0], [0.0, -1.0]], [[0.0], [1000.0]], [[1.0, 0.0]], [[0.0]], **kw)


CASES = [
    Case(id="plants-system-states-huge", call=lambda: ContinuousSystem(f=lambda t, x, u, p: -x, states=10**9),
         exc=ConfigurationError, names="1000000000"),
    Case(id="plants-system-f-not-callable", call=lambda: ContinuousSystem(f=1.0, states=1),
         exc=ConfigurationTypeError, names="1.0"),
    Case(id="plants-system-events-not-a-sequence",
         call=lambda: ContinuousSystem(f=lambda t, x, u, p: -x, states=1, events=1.0),
         exc=ConfigurationTypeError, names="1.0"),
    Case(id="plants-system-events-not-events",
         call=lambda: ContinuousSystem(f=lambda t, x, u, p: -x, states=1, events=["x"]),
         exc=ConfigurationTypeError, names="'x'"),
    # plant construction and x0
    Case(id="plants-system-int", call=lambda: _plant(42, []), exc=ConfigurationTypeError, names="42"),
    Case(id="plants-x0-length", call=lambda: Simulation().plant(DCServo(), x0=[0, 0, 0]), exc=ValueError,
         names="x0 has 3 entries"),
    Case(id="plants-x0-nan", call=lambda: Simulation().plant(DCServo(), x0=[math.nan, 0.0]),
         exc=ValueError, names="nan"),
    Case(id="plants-x0-inf", call=lambda: Simulation().plant(DCServo(), x0=[0.0, -math.inf]),
         exc=ValueError, names="-inf"),
    Case(id="plants-x0-none", call=lambda: Simulation().plant(DCServo(), x0=None), exc=TypeError, names="None"),
    Case(id="plants-x0-string", call=lambda: Simulation().plant(DCServo(), x0="00"), exc=TypeError, names="'00'"),
    Case(id="plants-x0-ragged", call=lambda: Simulation().plant(DCServo(), x0=[0.0, [1.0, 2.0]]),
         exc=ValueError, names="[0.0, [1.0, 2.0]]"),
    Case(id="plants-states-negative", call=lambda: ContinuousSystem(f=lambda t, x, u, p: x, states=-1),
         exc=ValueError, names="-1"),
    Case(id="plants-states-string", call=lambda: ContinuousSystem(f=lambda t, x, u, p: x, states="xy"),
         exc=TypeError, names="'xy'"),
    Case(id="plants-states-duplicate", call=lambda: ContinuousSystem(f=lambda t, x, u, p: x, states=["q", "q"]),
         exc=ValueError, names="'q'"),
    Case(id="plants-dcservo-k-zero", call=lambda: DCServo(k=0.0), exc=ValueError, names="0.0"),
    Case(id="plants-dcservo-k-nan", call=lambda: DCServo(k=math.nan), exc=ValueError, names="nan"),
    Case(id="plants-dcservo-a-negative", call=lambda: DCServo(a=-1.0), exc=ValueError, names="-1.0"),
    Case(id="plants-dcservo-k-string", call=lambda: DCServo(k="1000"), exc=TypeError, names="'1000'"),
    # integrators
    Case(id="plants-rk4-dt-below-resolution", call=lambda: RK4(dt=1e-15), exc=ValueError, names="1e-15"),
    Case(id="plants-rk4-dt-zero", call=lambda: RK4(dt=0.0), exc=ValueError, names="got 0.0"),
    Case(id="plants-rk4-dt-negative", call=lambda: RK4(dt=-1e-3), exc=ValueError, names="-0.001"),
    Case(id="plants-rk4-dt-nan", call=lambda: RK4(dt=math.nan), exc=ValueError, names="nan"),
    Case(id="plants-rk4-dt-inf", call=lambda: RK4(dt=math.inf), exc=ValueError, names="inf"),
    Case(id="plants-rk4-dt-string", call=lambda: RK4(dt="1ms"), exc=TypeError, names="'1ms'"),
    Case(id="plants-rk4-dt-bool", call=lambda: RK4(dt=True), exc=TypeError, names="True"),
    Case(id="plants-rk4-xtol-negative", call=lambda: RK4(xtol=-1e-9), exc=ValueError, names="-1e-09"),
    Case(id="plants-rk4-max-steps-zero", call=lambda: RK4(max_steps=0), exc=ValueError, names="got 0"),
    Case(id="plants-rk4-max-steps-float", call=lambda: RK4(max_steps=1.5e6), exc=TypeError, names="1500000.0"),
    Case(id="plants-rk4-advance-too-many-steps", call=_rk4_absurd_advance, exc=IntegrationError,
         names="dt=1e-12"),
    Case(id="plants-solveivp-method-unknown", call=lambda: SolveIVP(method="fast"), exc=ValueError,
         names="'fast'"),
    Case(id="plants-solveivp-method-case", call=lambda: SolveIVP(method="rk45"), exc=ValueError, names="'rk45'"),
    Case(id="plants-solveivp-method-not-solver", call=lambda: SolveIVP(method=dict), exc=ValueError,
         names="<class 'dict'>"),
    Case(id="plants-solveivp-rtol-nan", call=lambda: SolveIVP(rtol=math.nan), exc=ValueError, names="nan"),
    Case(id="plants-solveivp-rtol-inf", call=lambda: SolveIVP(rtol=math.inf), exc=ValueError, names="inf"),
    Case(id="plants-solveivp-atol-zero", call=lambda: SolveIVP(atol=0.0), exc=ValueError, names="0.0"),
    Case(id="plants-solveivp-max-step-zero", call=lambda: SolveIVP(max_step=0.0), exc=ValueError, names="0.0"),
    Case(id="plants-solveivp-max-step-nan", call=lambda: SolveIVP(max_step=math.nan), exc=ValueError,
         names="nan"),
    Case(id="plants-solveivp-max-evaluations-negative", call=lambda: SolveIVP(max_evaluations=-5),
         exc=ValueError, names="-5"),
    Case(id="plants-solveivp-max-evaluations-bool", call=lambda: SolveIVP(max_evaluations=True),
         exc=TypeError, names="True"),
    Case(id="plants-solveivp-budget-exceeded", call=_solve_ivp_budget, exc=IntegrationError,
         names="max_evaluations=200"),
    Case(id="plants-integrator-string", call=lambda: _servo(integrator="rk4"), exc=TypeError, names="'rk4'"),
    # logging
    Case(id="plants-log-mode", call=lambda: _servo(log="all"), exc=ValueError, names="'all'"),
    Case(id="plants-log-interval-negative", call=lambda: _servo(log_interval=-0.1), exc=ValueError, names="-0.1"),
    Case(id="plants-log-interval-nan", call=lambda: _servo(log_interval=math.nan), exc=ValueError, names="nan"),
    Case(id="plants-log-interval-below-resolution", call=lambda: _servo(log_interval=1e-13), exc=ValueError,
         names="1e-13"),
    Case(id="plants-log-interval-zero", call=lambda: _servo(log_interval=0.0), exc=ValueError, names="got 0.0"),
    # ports and writes
    Case(id="plants-output-unknown-name", call=lambda: _servo().output("z"), exc=KeyError, names="'z'"),
    Case(id="plants-input-index-out-of-range", call=lambda: _servo().input(5), exc=IndexError, names="index 5"),
    Case(id="plants-output-selector-float", call=lambda: _servo().output(0.5), exc=TypeError, names="0.5"),
    Case(id="plants-write-nan", call=lambda: _servo().input("u").write(math.nan), exc=ValueError, names="nan"),
    Case(id="plants-write-inf", call=lambda: _servo().input(0).write(math.inf), exc=ValueError, names="inf"),
    Case(id="plants-write-wrong-length", call=lambda: _servo().input(0).write([1.0, 2.0]), exc=ValueError,
         names="[1.0, 2.0]"),
    Case(id="plants-write-string", call=lambda: _servo().input(0).write("max"), exc=TypeError, names="'max'"),
    Case(id="plants-write-none", call=lambda: _servo().input(0).write(None), exc=TypeError, names="None"),
    Case(id="plants-output-nan", call=_nan_output_read, exc=IntegrationError, names="output level"),
    # disturbance and events
    Case(id="plants-disturbance-not-callable", call=lambda: _servo(disturbance=3.0), exc=TypeError, names="3.0"),
    Case(id="plants-disturbance-wrong-length", call=lambda: _disturbed(lambda t: [1.0, 2.0]),
         exc=ValueError, names="[1.0, 2.0]"),
    Case(id="plants-event-direction", call=lambda: HybridEvent("hit", lambda t, x, u, p: x[0], direction=2),
         exc=ValueError, names="got 2"),
    Case(id="plants-on-event-unknown", call=lambda: _servo().on_event("boom", lambda t: None), exc=KeyError,
         names="'boom'"),
    # python-control conversions
    Case(id="plants-control-discrete-ss", call=lambda: _plant(_pc_servo(dt=0.1), [0.0, 0.0]),
         exc=ValueError, names="dt=0.1"),
    Case(id="plants-control-discrete-tf",
         call=lambda: _plant(_control().tf([1.0], [1.0, -0.5], dt=True), [0.0]), exc=ValueError, names="dt=True"),
    Case(id="plants-control-x0-length", call=lambda: _plant(_pc_servo(), [0.0]), exc=ValueError,
         names="x0 has 1 entries"),
    Case(id="plants-control-frd", call=lambda: _plant(_control().frd(_pc_servo(), [1.0, 10.0]), []),
         exc=TypeError, names="FrequencyResponseData"),
    Case(id="plants-control-unknown-output", call=lambda: _plant(_pc_servo(), [0.0, 0.0]).output("y"),
         exc=KeyError, names="'y'"),
]

