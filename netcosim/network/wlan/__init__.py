"""IEEE 802.11b DCF: the network and its parameters (:mod:`~netcosim.network.wlan.network`),
the DCF rules station by station (:mod:`~netcosim.network.wlan.dcf`) and the shared idle-slot
clock (:mod:`~netcosim.network.wlan.shared`), the strategy the network uses instead while
every station hears every other one."""

from .dcf import DcfStation
from .network import BASIC_RATES, MAX_FRAME_SECONDS, RATES, WLAN80211b

__all__ = ["BASIC_RATES", "DcfStation", "MAX_FRAME_SECONDS", "RATES", "WLAN80211b"]
