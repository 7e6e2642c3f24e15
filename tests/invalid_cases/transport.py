"""Bad input to the HIL transport helpers: the CDR codec, the ROS 2 type hash, the client's loop."""

from __future__ import annotations

import math

from invalid_cases import Case
from netcosim.errors import ConfigurationError, ConfigurationTypeError


def _cdr():
    from netcosim.transport import cdr
    return cdr


def _periodic(period=0.01, duration=0.05):
    from netcosim.transport.client import periodic
    periodic(period, lambda k: False, duration=duration, sleep=lambda s: None)


CASES = [
    Case("cdr-decode-none", lambda: _cdr().decode(None), ConfigurationTypeError, "NoneType None"),
    Case("cdr-decode-text", lambda: _cdr().decode("frame"), ConfigurationTypeError, "'frame'"),
    Case("cdr-encode-text-value", lambda: _cdr().encode(1, 0, 0, 0, 0, 0, ("a",)), ConfigurationTypeError,
         "values[0] must be a real number, got 'a'"),
    Case("cdr-encode-ticks-beyond-int64", lambda: _cdr().encode(1, 0, 0, 0, 2**63, 0, ()), ConfigurationError,
         str(2**63)),
    Case("cdr-encode-float-ticks", lambda: _cdr().encode(1, 0, 0, 0, 0.5, 0, ()), ConfigurationError, "0.5"),
    Case("cdr-encode-node-out-of-range", lambda: _cdr().encode(1, 2**70, 0, 0, 0, 0, ()), ConfigurationError,
         str(2**70)),
    Case("cdr-rihs01-empty-type-name", lambda: _cdr().rihs01("", []), ConfigurationError, "got ''"),
    Case("cdr-rihs01-type-name-not-an-interface", lambda: _cdr().rihs01("Frame", []), ConfigurationError,
         "'Frame'"),
    Case("cdr-rihs01-bad-field", lambda: _cdr().rihs01("p/msg/T", [("x",)]), ConfigurationTypeError, "('x',)"),
    Case("client-periodic-duration-nan", lambda: _periodic(duration=math.nan), ConfigurationError, "nan"),
    Case("client-periodic-duration-negative", lambda: _periodic(duration=-1.0), ConfigurationError, "-1.0"),
    Case("client-periodic-period-inf", lambda: _periodic(period=math.inf), ValueError, "inf"),
]
