"""Radio physics: power units, path loss, thermal noise, bit error rates.

Conventions: powers in dBm at the API, watts inside; distances in metres; positions
are 2-D or 3-D points.  ``P_rx = P_tx * gain(d)`` with ``gain`` from a path-loss model.

Path loss
    :class:`LogDistance` -- ``PL(d) = PL(d0) + 10 n log10(d / d0)`` dB for ``d >= d0``
    (``PL(d0)`` = free-space Friis loss at ``d0`` and the carrier frequency unless
    given; ``d < d0`` is clamped to ``d0``).
    :class:`TrueTimePathLoss` -- TrueTime's ``P_rx = P_tx / (d + 1)^a`` (d in metres).

Noise
    :func:`thermal_noise_dbm` -- ``kTB`` plus a noise figure; 22 MHz at 290 K gives
    -100.6 dBm (the "-100 dBm background noise" TrueTime mentions).

Bit error rates (AWGN; interference treated as noise), as functions of Eb/N0 (linear)
    :func:`ber_dbpsk` ``= 1/2 exp(-Eb/N0)`` (802.11b 1 Mbit/s);
    :func:`ber_dqpsk` -- exact Gray-coded DQPSK with Marcum Q (802.11b 2 Mbit/s);
    :func:`ber_cck` -- a simple CCK model (5.5 and 11 Mbit/s): coherent QPSK
    ``Q(sqrt(2 Eb/N0))``, documented as an approximation.
    For a DSSS/CCK signal of bit rate R in bandwidth B = 22 MHz,
    ``Eb/N0 = SINR * B / R`` (the processing gain; ns-3 uses the same mapping).

A frame of ``n`` bits at a constant SINR decodes with probability ``(1 - BER)^n``;
with piecewise-constant interference the probabilities of the pieces multiply.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

from .. import validate
from ..errors import ConfigurationError, ConfigurationTypeError

#: Channel bandwidth of 802.11b DSSS/CCK (Hz): noise bandwidth and processing-gain reference.
DSSS_BANDWIDTH = 22e6
#: 802.11b channel 1 centre frequency (Hz).
CHANNEL_1 = 2.412e9
#: Boltzmann constant (J/K) and speed of light (m/s), exact SI values (as scipy.constants).
BOLTZMANN = 1.380649e-23
SPEED_OF_LIGHT = 299792458.0


def dbm_to_watt(dbm: float) -> float:
    """Power *dbm* (dBm) in watts: ``10**((dbm - 30) / 10)``.

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationTypeError`
        *dbm* is not a number.
    :class:`~netcosim.errors.ConfigurationError`
        *dbm* is NaN or infinite, or so large (above about 3000 dBm) that the power in
        watts overflows.

    Examples
    --------
    >>> from netcosim.network import dbm_to_watt
    >>> dbm_to_watt(30.0), dbm_to_watt(0.0)
    (1.0, 0.001)
    >>> round(dbm_to_watt(15.0), 6)          # 802.11b's default transmit power, in W
    0.031623
    """
    v = validate.finite(dbm, "power (dBm)", "dBm")
    try:
        return 10.0 ** ((v - 30.0) / 10.0)
    except OverflowError:           # above about 3100 dBm
        raise ConfigurationError(f"power (dBm) must be at most 3000 dBm, got {dbm!r}") from None


def watt_to_dbm(w: float) -> float:
    """Power *w* (W) in dBm: ``10 log10(w) + 30``; ``-inf`` for zero power.

    A negative, NaN or infinite *w* raises :class:`~netcosim.errors.ConfigurationError`,
    a *w* that is not a number :class:`~netcosim.errors.ConfigurationTypeError`.

    Examples
    --------
    >>> from netcosim.network import watt_to_dbm
    >>> watt_to_dbm(1e-3), watt_to_dbm(0.0)
    (0.0, -inf)
    >>> round(watt_to_dbm(2.0), 2)           # twice 1 W: +3 dB
    33.01
    """
    w = validate.non_negative(w, "power (W)")
    return -math.inf if w <= 0 else 10.0 * math.log10(w) + 30.0


def db_to_ratio(db: float) -> float:
    """A gain or ratio in dB (*db*) as a linear power ratio."""
    return 10.0 ** (db / 10.0)


def thermal_noise_dbm(bandwidth: float = DSSS_BANDWIDTH, temperature: float = 290.0,
                      noise_figure_db: float = 0.0) -> float:
    """Thermal noise power ``k T B`` in dBm plus the receiver noise figure (dB).

    ``bandwidth`` [Hz] and ``temperature`` [K] must be positive and finite;
    ``noise_figure_db`` [dB] finite and >= 0 (a receiver adds noise, never removes it);
    otherwise :class:`~netcosim.errors.ConfigurationError` (a value out of range) or
    :class:`~netcosim.errors.ConfigurationTypeError` (not a number), naming it.

    Examples
    --------
    The noise floor of 802.11b (22 MHz) and of 802.15.4 (2 MHz) at 290 K, and with a
    7 dB receiver noise figure:

    >>> from netcosim.network import thermal_noise_dbm
    >>> round(thermal_noise_dbm(22e6), 2), round(thermal_noise_dbm(2e6), 2)
    (-100.55, -110.96)
    >>> round(thermal_noise_dbm(22e6, noise_figure_db=7.0), 2)
    -93.55
    """
    bandwidth = validate.positive(bandwidth, "thermal noise bandwidth (Hz)")
    temperature = validate.positive(temperature, "thermal noise temperature (K)")
    noise_figure_db = validate.non_negative(noise_figure_db, "receiver noise_figure_db (dB)")
    return watt_to_dbm(BOLTZMANN * temperature * bandwidth) + noise_figure_db


# ---------------------------------------------------------------------------- path loss

class PathLoss:
    """Base class: ``gain(d)`` is the linear power gain at distance *d* metres."""

    def gain(self, d: float) -> float:
        """Linear power gain (``P_rx / P_tx``, in (0, 1]) at distance *d* (m)."""
        raise NotImplementedError

    def loss_db(self, d: float) -> float:
        """Path loss (dB, positive) at distance *d* (m): ``-10 log10(gain(d))``."""
        return -10.0 * math.log10(self.gain(d))

    def rx_dbm(self, tx_dbm: float, d: float) -> float:
        """Received power (dBm) at distance *d* for transmit power *tx_dbm*."""
        return tx_dbm - self.loss_db(d)


class LogDistance(PathLoss):
    """Log-distance path loss ``PL(d) = PL(d0) + 10 n log10(d/d0)`` dB (d clamped to >= d0).

    ``exponent`` n (dimensionless), ``reference_distance`` d0 [m] and ``frequency``
    [Hz] must be positive and finite.  ``reference_loss_db`` [dB] is the loss at d0:
    finite and >= 0 (a passive channel does not amplify); ``None`` uses the free-space
    (Friis) loss at ``d0`` and ``frequency``: ``20 log10(4 pi d0 f / c)`` (40.1 dB at
    1 m and 2.412 GHz).  The radio networks take it as ``path_loss=``
    (:class:`~netcosim.network.wlan.WLAN80211b`, :class:`~netcosim.network.lrwpan.IEEE802154`).

    Raises
    ------
    :class:`~netcosim.errors.ConfigurationError`
        ``exponent``, ``reference_distance`` or ``frequency`` not positive and finite,
        ``reference_loss_db`` negative or not finite.
    :class:`~netcosim.errors.ConfigurationTypeError`
        A parameter that is not a number.

    Examples
    --------
    With exponent 3, ten times farther is 30 dB more loss; 15 dBm sent, at 10 m:

    >>> from netcosim.network import LogDistance
    >>> pl = LogDistance(exponent=3.0)
    >>> round(pl.loss_db(1.0), 2), round(pl.loss_db(10.0), 2)
    (40.1, 70.1)
    >>> round(pl.rx_dbm(15.0, 10.0), 2)
    -55.1
    """

    def __init__(self, exponent: float = 3.0, reference_distance: float = 1.0,
                 reference_loss_db: float | None = None, frequency: float = CHANNEL_1):
        self.exponent = validate.positive(exponent, "LogDistance exponent")
        self.d0 = validate.positive(reference_distance, "LogDistance reference_distance (m)")
        self.frequency = validate.positive(frequency, "LogDistance frequency (Hz)")
        if reference_loss_db is None:
            reference_loss_db = 20.0 * math.log10(4.0 * math.pi * self.d0 * self.frequency / SPEED_OF_LIGHT)
        self.pl0 = validate.non_negative(reference_loss_db, "LogDistance reference_loss_db (dB)")

    def loss_db(self, d: float) -> float:
        """Path loss (dB) at distance *d* (m), with *d* clamped to at least ``d0``; a
        negative or NaN *d* raises :class:`~netcosim.errors.ConfigurationError` naming it."""
        if not d > self.d0:             # rare path: within d0, or not a distance
            if not d >= 0.0:
                raise ConfigurationError(f"LogDistance: distance must be >= 0 m, got {d!r}")
            d = self.d0
        return self.pl0 + 10.0 * self.exponent * math.log10(d / self.d0)

    def gain(self, d: float) -> float:
        """Linear power gain at distance *d* (m): ``10^(-loss_db(d)/10)``."""
        return 10.0 ** (-self.loss_db(d) / 10.0)

    def __repr__(self):
        return f"LogDistance(exponent={self.exponent}, d0={self.d0}, PL(d0)={self.pl0:.2f} dB)"


class TrueTimePathLoss(PathLoss):
    """TrueTime's model: ``P_rx = P_tx / (d + 1)^a`` with d in metres (``exponent`` a, default
    3.5; positive and finite, else :class:`~netcosim.errors.ConfigurationError`).

    Examples
    --------
    At 9 m the gain is ``10**-3.5``, a loss of 35 dB:

    >>> from netcosim.network import TrueTimePathLoss
    >>> pl = TrueTimePathLoss(exponent=3.5)
    >>> pl.gain(9.0) == 10 ** -3.5, round(pl.loss_db(9.0), 6)
    (True, 35.0)

    On a network: ``WLAN80211b(sim, "wlan", path_loss=TrueTimePathLoss())``.
    """

    def __init__(self, exponent: float = 3.5):
        self.exponent = validate.positive(exponent, "TrueTimePathLoss exponent")

    def gain(self, d: float) -> float:
        """Linear power gain ``(d + 1)^-a`` at distance *d* (m); a negative or NaN *d*
        raises :class:`~netcosim.errors.ConfigurationError` naming it."""
        if d >= 0.0:
            return (d + 1.0) ** (-self.exponent)
        raise ConfigurationError(f"TrueTimePathLoss: distance must be >= 0 m, got {d!r}")

    def __repr__(self):
        return f"TrueTimePathLoss(exponent={self.exponent})"


def as_position(p, what: str) -> tuple[float, ...] | Callable:
    """A fixed 2-D/3-D position *p* (m) as a tuple of floats, or a callable ``p(t) -> point`` as
    is; *what* names the position's owner in the error for a bad one."""
    if callable(p):
        return p
    try:
        if isinstance(p, (str, bytes)):
            raise TypeError
        v = tuple(float(x) for x in p)
    except (TypeError, ValueError):
        raise ConfigurationTypeError(f"{what}: position must be a 2-D/3-D point or a callable p(t), "
                                     f"got {p!r}") from None
    if len(v) not in (2, 3) or not all(math.isfinite(x) for x in v):
        raise ConfigurationError(f"{what}: position must be 2 or 3 finite coordinates (m), got {p!r}")
    return v


def distance(a: Sequence[float], b: Sequence[float]) -> float:
    """Euclidean distance (m) between points *a* and *b* (m); a 2-D point lies in the plane z = 0."""
    if len(a) == len(b):
        return math.dist(a, b)
    a3 = tuple(a) + (0.0,) * (3 - len(a))
    b3 = tuple(b) + (0.0,) * (3 - len(b))
    return math.dist(a3, b3)


# ---------------------------------------------------------------------------- bit errors

def linear_ratio(value, what: str = "Eb/N0") -> np.ndarray:
    """*value* (a number or an array) as a float array of linear power ratios: each
    ``>= 0`` or ``inf``; :class:`ConfigurationError` naming the value for a negative one
    (a ratio in dB passed where a linear one is expected) or NaN,
    :class:`ConfigurationTypeError` for what is not real numbers."""
    if value is None or isinstance(value, (str, bytes)) or (
            isinstance(value, np.ndarray) and value.dtype.kind not in "fiub"):
        raise ConfigurationTypeError(f"{what} must be a linear power ratio (a real number >= 0), got {value!r}")
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigurationTypeError(f"{what} must be a linear power ratio (a real number >= 0), "
                                     f"got {value!r}") from None
    if not (a >= 0.0).all():     # NaN fails the comparison too
        raise ConfigurationError(f"{what} must be a linear power ratio >= 0 (not dB, not NaN), got {value!r}")
    return a


def ber_dbpsk(ebn0):
    """Bit error rate of differential BPSK: ``1/2 exp(-Eb/N0)`` at *ebn0*, Eb/N0 (linear, not dB,
    >= 0; a number or an array).

    A negative or NaN *ebn0* (a value in dB, say) raises
    :class:`~netcosim.errors.ConfigurationError`.

    Examples
    --------
    At Eb/N0 = 4 (6 dB), ``exp(-4) / 2``; an array gives an array:

    >>> from netcosim.network import ber_dbpsk
    >>> round(ber_dbpsk(4.0), 6)
    0.009158
    >>> [round(float(b), 6) for b in ber_dbpsk([0.0, 1.0])]
    [0.5, 0.18394]
    """
    if type(ebn0) is float and ebn0 >= 0.0:
        return 0.5 * math.exp(-ebn0)
    g = linear_ratio(ebn0)
    return 0.5 * np.exp(-g) if np.ndim(ebn0) else float(0.5 * np.exp(-g))


def ber_dqpsk(ebn0):
    """Exact bit error rate of Gray-coded DQPSK (Proakis): ``Q1(a, b) - 1/2 I0(ab) exp(-(a^2+b^2)/2)``.

    ``a = sqrt(2 g (1 - 1/sqrt 2))``, ``b = sqrt(2 g (1 + 1/sqrt 2))``, ``g = Eb/N0``;
    Marcum Q1 via the non-central chi-square survival function.  *ebn0*: ``Eb/N0``, linear
    (not dB), >= 0, a number or an array;
    above 10**4 the BER is 0.0 in double precision and is computed at 10**4.  A negative or
    NaN *ebn0* raises :class:`~netcosim.errors.ConfigurationError`.

    Examples
    --------
    At the same Eb/N0 = 4 (6 dB) DQPSK errs about twice as often as DBPSK
    (:func:`ber_dbpsk`: 0.009158):

    >>> from netcosim.network import ber_dqpsk
    >>> round(ber_dqpsk(4.0), 6)
    0.017013
    """
    g = np.minimum(linear_ratio(ebn0), 1e4)
    a = np.sqrt(2.0 * g * (1.0 - 1.0 / math.sqrt(2.0)))
    b = np.sqrt(2.0 * g * (1.0 + 1.0 / math.sqrt(2.0)))
    from scipy import special, stats  # loaded on first use: most runs never need it
    q1 = stats.ncx2.sf(b * b, 2, a * a)
    # I0(ab) exp(-(a^2+b^2)/2) = i0e(ab) exp(-(a-b)^2/2), numerically safe
    ber = q1 - 0.5 * special.i0e(a * b) * np.exp(-0.5 * (a - b) ** 2)
    ber = np.clip(ber, 0.0, 0.5)
    return float(ber) if np.ndim(ebn0) == 0 else ber


def ber_cck(ebn0):
    """Simple CCK model: coherent QPSK bit error rate ``Q(sqrt(2 Eb/N0)) = 1/2 erfc(sqrt(Eb/N0))``
    of *ebn0*, Eb/N0 (linear, not dB, >= 0; a number or an array).

    A negative or NaN *ebn0* raises :class:`~netcosim.errors.ConfigurationError`.

    Examples
    --------
    At Eb/N0 = 4 (6 dB), ``erfc(2) / 2``:

    >>> from netcosim.network import ber_cck
    >>> round(ber_cck(4.0), 6)
    0.002339
    >>> ber_cck(-3.0)
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationError: Eb/N0 must be a linear power ratio >= 0 (not dB, not NaN), got -3.0
    """
    from scipy import special
    g = linear_ratio(ebn0)
    ber = 0.5 * special.erfc(np.sqrt(g))
    return float(ber) if np.ndim(ebn0) == 0 else ber


class Modulation:
    """A modulation with its bit rate: ``ber(sinr)`` maps a linear SINR to a bit error rate.

    ``name``: its name (e.g. ``"dqpsk"``); ``bit_rate`` (bit/s); ``ber_of_ebn0``: the bit
    error rate as a function of a linear Eb/N0 (e.g. :func:`ber_dqpsk`); ``bandwidth``
    (Hz, default the 22 MHz of 802.11b's DSSS): with the bit rate, the processing gain
    ``B / R`` that turns the SINR into Eb/N0."""

    def __init__(self, name: str, bit_rate: float, ber_of_ebn0: Callable, bandwidth: float = DSSS_BANDWIDTH):
        self.name = name
        self.bit_rate = float(bit_rate)
        self._f = ber_of_ebn0
        self.gain = bandwidth / self.bit_rate      # processing gain B / R
        # Above this Eb/N0 the BER is below 1e-30: skip the special functions.
        self._cut = 75.0
        self._cache: dict = {}

    def ber(self, sinr: float) -> float:
        """Bit error rate at signal-to-interference-plus-noise ratio *sinr* (linear, not dB):
        ``ber_of_ebn0(sinr * B / R)``."""
        ebn0 = sinr * self.gain
        if ebn0 >= self._cut:
            return 0.0
        c = self._cache
        v = c.get(ebn0)
        if v is None:
            if len(c) > 4096:
                c.clear()
            v = c[ebn0] = float(self._f(ebn0))
        return v

    def __repr__(self):
        return f"Modulation({self.name}, {self.bit_rate:g} bit/s)"


def modulation_for(rate: float, kind: str = "auto") -> Modulation:
    """The 802.11b modulation used at *rate* bit/s.

    ``kind="auto"``: DBPSK up to 1 Mbit/s, DQPSK up to 2 Mbit/s, CCK above (the BER
    is evaluated at the actual rate, so 1.2 Mbit/s is "DQPSK at 1.2 Mbit/s").
    Or force ``"dbpsk"``, ``"dqpsk"``, ``"cck"``.
    """
    rate = validate.positive(rate, "modulation bit rate (bit/s)")
    f = {"dbpsk": ber_dbpsk, "dqpsk": ber_dqpsk, "cck": ber_cck}.get(kind) if isinstance(kind, str) else None
    if kind == "auto":
        kind = "dbpsk" if rate <= 1e6 else ("dqpsk" if rate <= 2e6 else "cck")
        f = {"dbpsk": ber_dbpsk, "dqpsk": ber_dqpsk, "cck": ber_cck}[kind]
    if f is None:
        raise ConfigurationError(f"modulation must be 'auto', 'dbpsk', 'dqpsk' or 'cck', got {kind!r}")
    return Modulation(kind, rate, f)
