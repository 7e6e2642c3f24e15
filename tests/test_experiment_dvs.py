"""The DVS experiment: energy against speed follows the power model; the lowest safe speed misses
no deadline, a lower one does; cycle-conserving DVS saves more than static DVS."""

import pytest

from netcosim.experiments import dvs


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    return dvs.main(str(tmp_path_factory.mktemp("dvs")), until=0.12)


def test_energy_falls_with_speed_as_the_model_says(table):
    fixed = table[table["mode"] == "fixed"].set_index("speed")
    # the same work W (J at speed 1 and 1 W) at every speed: E = 0.05 T + W s^2, with W from speed 1
    T = 0.12
    work = fixed.loc[1.0, "energy_J"] - 0.05 * T
    for s in (0.8, 0.6, 0.45):
        assert fixed.loc[s, "energy_J"] == pytest.approx(0.05 * T + work * s * s, rel=0.02)
    assert fixed["energy_J"].is_monotonic_decreasing


def test_lowest_safe_speed_meets_deadlines_and_below_it_misses(table):
    fixed = table[table["mode"] == "fixed"].set_index("speed")
    assert fixed.loc[dvs.U_WORST, "misses"] == 0
    assert fixed.loc[0.2, "misses"] > 0
    cc = table[table["mode"] == "cycle-conserving"].iloc[0]
    assert cc["misses"] == 0
    assert cc["energy_J"] < fixed.loc[dvs.U_WORST, "energy_J"]
