"""TrueTime's wireless example with batteries: transmit-power control saves energy; without it the
controller's battery runs empty after about 4.9 s (0.3 J at 10 mW + about 51 mW of radio at 30 dBm)."""

import math

import pytest

from netcosim.experiments import wireless_tpc


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    return wireless_tpc.main(str(tmp_path_factory.mktemp("tpc")), quick=True).set_index("tpc")


def test_without_tpc_the_controller_battery_empties_and_control_is_lost(table):
    off = table.loc[False]
    # controller: 10 mW kernel, 320-bit frames (0.4 ms) at 1 W every 10 ms, and 88-bit ACKs (0.11 ms)
    # of the sensor's frames: 0.3 J / (0.01 + 0.04 + 0.011) W = 4.92 s (ACK and CSMA details aside)
    assert off["controller_empty_at_s"] == pytest.approx(0.3 / 0.061, rel=0.01)
    assert off["controller_energy_J"] == pytest.approx(0.3, rel=1e-12)


def test_tpc_saves_energy_and_keeps_control(table):
    on = table.loc[True]
    assert math.isnan(on["controller_empty_at_s"]) and math.isnan(on["sensor_empty_at_s"])
    assert on["controller_energy_J"] < 0.22 and on["sensor_energy_J"] < 0.2
    assert on["iae"] < 1.0


def test_figure_written(tmp_path):
    wireless_tpc.main(str(tmp_path), until=0.3)
    assert (tmp_path / "wireless_tpc.png").stat().st_size > 10_000
