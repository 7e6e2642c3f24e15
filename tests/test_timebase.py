"""The time base: seconds at the API, integer picosecond ticks inside."""

import math

import pytest

from netcosim.errors import ConfigurationError, ConfigurationTypeError
from netcosim.timebase import RESOLUTION, TICKS_PER_SECOND, to_seconds, to_ticks


def test_resolution_and_ticks_per_second_agree():
    assert RESOLUTION == 1e-12 and TICKS_PER_SECOND == 10**12


@pytest.mark.parametrize("seconds, ticks", [(0.0, 0), (1e-12, 1), (0.006, 6_000_000_000), (2.9e-3, 2_900_000_000),
                                            (1.5, 1_500_000_000_000), (3600.0, 3_600_000_000_000_000)])
def test_seconds_round_to_the_nearest_tick(seconds, ticks):
    assert to_ticks(seconds) == ticks


def test_release_instants_are_exact_multiples_however_many_periods():
    # offset + k*period in integers: the 10^6-th release of a 6 ms task is exactly 6000 s
    period = to_ticks(0.006)
    assert 10**6 * period == to_ticks(6000.0)
    assert to_seconds(10**6 * period) == 6000.0
    # while accumulating the float period drifts
    t = 0.0
    for _ in range(10**5):
        t += 0.006
    assert t != 600.0


def test_to_seconds_is_correctly_rounded():
    assert to_seconds(2 * 10**11) == 0.2
    assert to_seconds(1) == 1e-12


def test_negative_instants_only_when_allowed():
    assert to_ticks(-0.5, allow_negative=True) == -500_000_000_000
    with pytest.raises(ConfigurationError, match="offset must be non-negative, got -0.5"):
        to_ticks(-0.5, "offset")


@pytest.mark.parametrize("value", [1e-13, 4.9e-13, 5e-13, -1e-13])
def test_non_zero_values_below_the_resolution_are_refused(value):
    with pytest.raises(ConfigurationError, match=f"period={value!r} s is non-zero but below the time resolution"):
        to_ticks(value, "period", allow_negative=True)


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_non_finite_values_are_refused(value):
    with pytest.raises(ConfigurationError, match=f"until must be finite, got {value!r}"):
        to_ticks(value, "until")


@pytest.mark.parametrize("value", ["1", None, True, 1j])
def test_non_numbers_are_refused(value):
    with pytest.raises(ConfigurationTypeError, match=f"got {value!r}"):
        to_ticks(value, "delay")
