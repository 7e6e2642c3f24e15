"""Networks: frames, interfaces, MAC/PHY models, loss models, radio.

Create a network with its simulation and a name, attach nodes, send from tasks::

    net = CAN(sim, "can", data_rate=500e3)
    iface = net.attach(node, priority=3)
    ...
    ctx.send("controller", payload, size_bits=64)       # in a task body

Models: :class:`IdealLink`, :class:`FDMA`, :class:`CSMACD`, :class:`CAN`,
:class:`RoundRobin`, :class:`TDMA`, :class:`SwitchedEthernet`, :class:`WLAN80211b`,
:class:`IEEE802154`, :class:`SlottedAloha` (the minimal example MAC).
Loss models: :class:`Bernoulli`, :class:`GilbertElliott`, :class:`TraceLoss`; ``loss=`` is a frame loss,
``message_loss=`` a message loss; ``network.stats`` and :func:`loss_summary` count both.
See ``docs/networks.md`` for the semantics of each model.
"""

from .aloha import SlottedAloha
from .base import ARBITRATE, NETWORK_STATES, Network
from .bus import RoundRobin, SharedBus
from .can import CAN, can_frame_bits
from .ethernet import CSMACD
from .frame import BROADCAST, LOSS_REASONS, Message
from .ideal import FDMA, IdealLink
from .interface import Interface
from .loss import AnyLoss, Bernoulli, GilbertElliott, LossModel, MarkovChannel, MaskedLossWarning, TraceLoss
from .lrwpan import IEEE802154
from .radio import (
    LogDistance,
    TrueTimePathLoss,
    ber_cck,
    ber_dbpsk,
    ber_dqpsk,
    dbm_to_watt,
    thermal_noise_dbm,
    watt_to_dbm,
)
from .stats import LinkStats, loss_summary
from .switched import SwitchedEthernet
from .tdma import TDMA
from .traffic import SaturatedSource
from .wireless import RadioNetwork, RadioStation
from .wlan import RATES, WLAN80211b

__all__ = ["ARBITRATE", "AnyLoss", "BROADCAST", "Bernoulli", "CAN", "CSMACD", "FDMA", "GilbertElliott",
           "IEEE802154", "IdealLink", "Interface", "LOSS_REASONS", "LinkStats", "LogDistance", "LossModel",
           "MarkovChannel", "MaskedLossWarning", "Message",
           "NETWORK_STATES", "Network", "RATES", "RadioNetwork", "RadioStation", "RoundRobin", "SaturatedSource",
           "SharedBus", "SlottedAloha", "SwitchedEthernet", "TDMA", "TraceLoss", "TrueTimePathLoss", "WLAN80211b",
           "ber_cck", "ber_dbpsk", "ber_dqpsk", "can_frame_bits", "dbm_to_watt", "loss_summary", "thermal_noise_dbm",
           "watt_to_dbm"]
