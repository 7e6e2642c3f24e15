"""The tethered UAV as a model-exchange FMU generated from its CasADi model
(``build_casadi_fmu``, ``plants/tethered_uav_fmu.py``), run through the landing loop in
place of the Python plant under the same schedule: same outputs, same hybrid events.

The FMUs are built once per session (gcc, FMPy); the tests skip without them.
"""

import math
import shutil
import zipfile

import numpy as np
import pytest

from netcosim.controllers.landing.scenario import LandingScenario
from netcosim.controllers.landing.topology import build_landing
from netcosim.errors import ConfigurationError

fmi = pytest.importorskip("netcosim.fmi")
ca = pytest.importorskip("casadi")


@pytest.fixture(scope="session")
def uav_fmus(tmp_path_factory):
    """``get(inputs, wind, fmi)``: the path of the UAV FMU, built once per session."""
    pytest.importorskip("fmpy", reason="FMPy (pip install 'netcosim[fmi]') is not installed")
    if shutil.which("gcc") is None:
        pytest.skip("gcc is needed to build the FMUs")
    from netcosim.plants.tethered_uav_fmu import build_uav_fmu
    root = tmp_path_factory.mktemp("uav_fmus")
    cache: dict = {}

    def get(inputs, wind, fmi=2):
        key = (inputs, wind, fmi)
        if key not in cache:
            cache[key] = build_uav_fmu(root / f"b{len(cache)}", inputs=inputs, wind=wind, fmi=fmi)
        return cache[key]
    return get


def landing(controller, wind, until, fmu=None):
    """Outputs (times, values: one column per output) and event log of the landing loop."""
    from netcosim.fmi import ModelExchangeFMU
    sc = LandingScenario(controller=controller, wind=wind, duration=until)
    system = None if fmu is None else ModelExchangeFMU(fmu, name="tethered_uav")
    sim, uav, _loop = build_landing(sc, system=system)
    sim.run(until)
    s = sim.trace.signals()
    s = s[(s["source"] == "uav") & s["signal"].str.startswith("y.")]
    names = list(dict.fromkeys(s["signal"]))
    cols = [s[s["signal"] == n] for n in names]
    return cols[0]["time"].to_numpy(), np.column_stack([c["value"].to_numpy() for c in cols]), names, uav.event_log


def test_uav_fmu_matches_python_plant_in_the_2lc_landing_with_wind_and_touchdown(uav_fmus):
    """2LC (NMPC 10 ms + FL 2 ms on one node, RK4 0.1 ms), wind on, 0.6 s: the vehicle touches
    the landers at t = 0.4727 s.  Measured: outputs equal to 8.9e-16 (f_L; the rest 0.0),
    events at the same instants (wind pulse end 0.05 s, sine start 0.1 s, touchdown)."""
    t_p, y_p, names_p, ev_p = landing("2lc", True, 0.6)
    t_f, y_f, names_f, ev_f = landing("2lc", True, 0.6, uav_fmus("forces", True))
    assert names_f == [n.replace("f_R", "f_R_out").replace("tau_R", "tau_R_out") if n in ("y.f_R", "y.tau_R")
                       else n for n in names_p]
    assert y_p.shape == y_f.shape == (600, 10)
    np.testing.assert_array_equal(t_p, t_f)
    assert np.max(np.abs(y_p - y_f)) <= 1e-8
    assert [e for _, e in ev_p] == ["wind_pulse_end", "wind_sine_start", "touchdown"]
    assert [e for _, e in ev_f] == ["z1", "z2", "z0"]      # indicators: contact, pulse end, sine start
    assert np.max(np.abs(np.array([t for t, _ in ev_p]) - [t for t, _ in ev_f])) <= 1e-12
    assert 0.45 < ev_p[2][0] < 0.5
    assert np.max(y_p[:, names_p.index("y.f_RF")]) > 0.0      # the lander reaction acted


def test_uav_fmu_matches_python_plant_under_nmpc_rates(uav_fmus):
    """NMPC alone (rates model, 6 states), no wind, 0.3 s: outputs equal to 1e-8 (observed 0)."""
    _, y_p, names_p, ev_p = landing("nmpc", False, 0.3)
    _, y_f, names_f, ev_f = landing("nmpc", False, 0.3, uav_fmus("rates", False))
    assert names_f == names_p and y_p.shape == (300, 10)
    assert np.max(np.abs(y_p - y_f)) <= 1e-8
    assert abs(y_p[-1, 0] - y_p[0, 0]) > 1e-3      # the vehicle moved (phi changed)
    assert [t for t, _ in ev_p] == [t for t, _ in ev_f] == [0.05, 0.1]


def test_uav_fmu_description_names_units_and_fmi3(uav_fmus):
    from netcosim.fmi import ModelExchangeFMU
    me = ModelExchangeFMU(uav_fmus("forces", False), name="uav")
    assert me.state_names == ("phi", "dphi", "theta", "dtheta")
    assert me.input_names == ("f_R", "tau_R")
    assert me.units["dphi"] == "rad/s" and me.units["tau_R_out"] == "N.m" and me.units["d_PG1"] == "m"
    assert len(me.events) == 4           # 3 indicators and the time event
    with zipfile.ZipFile(uav_fmus("forces", False)) as z:
        assert "sources/tethered_uav_forces2_casadi.c" in z.namelist()
        assert "<CoSimulation" not in z.read("modelDescription.xml").decode()
    # FMI 3: derivative at a state/input point equals the Python plant's f
    from netcosim.plants.tethered_uav import TetheredUAV
    me3 = ModelExchangeFMU(uav_fmus("rates", False, 3), name="uav3")
    py = TetheredUAV(inputs="rates")
    x, u = np.array([0.3, -0.1, 0.05, 0.2, 7.0, 0.01]), np.array([1.0, -0.5])
    np.testing.assert_allclose(me3.f(0.0, x, u, me3.params), py.f(0.0, x, np.r_[u, 0.0, 0.0], py.params),
                               rtol=0, atol=1e-12)
    np.testing.assert_allclose(me3.h(0.0, x, u, me3.params), py.h(0.0, x, np.r_[u, 0.0, 0.0], py.params),
                               rtol=0, atol=1e-12)


def test_build_casadi_fmu_generic_first_order_and_bad_input(tmp_path):
    """A 1-state plant x' = -x/tau + u/tau (tau = 0.5 s) with output 2x: analytic step response."""
    pytest.importorskip("fmpy")
    if shutil.which("gcc") is None:
        pytest.skip("gcc is needed")
    from netcosim import Simulation
    from netcosim.fmi import ModelExchangeFMU
    from netcosim.fmi.casadi_fmu import build_casadi_fmu
    from netcosim.plant import SolveIVP
    t, x, u = ca.SX.sym("t"), ca.SX.sym("x"), ca.SX.sym("u")
    f = ca.Function("f", [t, x, u], [(u - x) / 0.5])
    h = ca.Function("h", [t, x, u], [ca.vertcat(x, 2 * x)])
    path = build_casadi_fmu("lag", tmp_path, f=f, h=h, states=["x"], inputs=["u"], outputs=["x", "y"],
                            units={"x": "m", "u": "m", "y": "m"}, start={"x": 0.25})
    me = ModelExchangeFMU(path)
    assert me.x0.tolist() == [0.25] and me.units == {"x": "m", "u": "m", "y": "m"}
    with zipfile.ZipFile(path) as z:
        assert 'name="der(x)"' in (xml := z.read("modelDescription.xml").decode()) and 'unit="m/s"' in xml
    sim = Simulation()
    plant = sim.plant(me, me.x0, integrator=SolveIVP(rtol=1e-10, atol=1e-12))
    plant.input("u").write(1.0)
    sim.run(1.0)
    assert abs(float(plant.output("y").read()) - 2 * (1 - 0.75 * math.exp(-2.0))) < 1e-8
    with pytest.raises(ConfigurationError, match="outputs \\['u'\\] are named like inputs"):
        build_casadi_fmu("lag", tmp_path, f=f, h=h, states=["x"], inputs=["u"], outputs=["x", "u"])
    with pytest.raises(ConfigurationError, match="f must take"):
        build_casadi_fmu("lag", tmp_path, f=ca.Function("f", [x, u], [x]), h=h, states=["x"], inputs=["u"],
                         outputs=["x", "y"])
    with pytest.raises(ConfigurationError, match="h must return one vector of 3"):
        build_casadi_fmu("lag", tmp_path, f=f, h=h, states=["x"], inputs=["u"], outputs=["x", "y", "z"])
    with pytest.raises(ConfigurationError, match="start values for unknown names \\['q'\\]"):
        build_casadi_fmu("lag", tmp_path, f=f, h=h, states=["x"], inputs=["u"], outputs=["x", "y"], start={"q": 1})
