"""IEEE 802.11b DCF: the network (:mod:`.network`), the per-station DCF rules (:mod:`.dcf`)
and the shared idle-slot clock (:mod:`.shared`) that the network uses instead while every
station hears every other one."""

from .network import BASIC_RATES, RATES, DcfStation, WLAN80211b

__all__ = ["BASIC_RATES", "DcfStation", "RATES", "WLAN80211b"]
