"""Bad input to ``netcosim.network.loss_summary``: not a simulation, no network, an unknown network."""

from __future__ import annotations

from invalid_cases import Case
from netcosim.errors import ConfigurationError, ConfigurationTypeError


def _summary(sim_with_network=False, network=None, sim=None):
    from netcosim import Simulation
    from netcosim.network import IdealLink, loss_summary
    if sim is None:
        sim = Simulation()
        if sim_with_network:
            IdealLink(sim, "link", data_rate=1e6)
    return loss_summary(sim, network)


CASES = [
    Case("loss-summary-not-a-simulation", lambda: _summary(sim=42), ConfigurationTypeError, "int 42"),
    Case("loss-summary-no-network", lambda: _summary(), ConfigurationError, "has no network"),
    Case("loss-summary-unknown-network", lambda: _summary(True, "wlan"), ConfigurationError, "'wlan'"),
]
