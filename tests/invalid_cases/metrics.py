"""Bad input to ``netcosim.metrics``: NaN values, an empty window, unknown signals."""

from __future__ import annotations

import pandas as pd

from invalid_cases import Case
from netcosim import metrics
from netcosim.errors import ConfigurationError
from netcosim.trace import UnknownSignalError

NAN = float("nan")
TABLE = pd.DataFrame({"time": [0.0, 1.0, 2.0], "source": "p", "signal": "y", "value": [1.0, 2.0, 3.0]})

CASES = [
    Case(id="metrics-iae-nan-value", call=lambda: metrics.iae([0, 1, 2.0], [1, NAN, 1.0]), exc=ConfigurationError,
         names="index 1 (t=1.0 s) is NaN"),
    Case(id="metrics-ise-nan-in-a-series", call=lambda: metrics.ise(pd.Series([1.0, 2.0, NAN], index=[0, 1, 2.0])),
         exc=ConfigurationError, names="index 2 (t=2.0 s) is NaN"),
    Case(id="metrics-quadratic-cost-nan-value", call=lambda: metrics.quadratic_cost([0, 1, 2.0], [1, NAN, 1.0]),
         exc=ConfigurationError, names="index 1 (t=1.0 s) is NaN"),
    Case(id="metrics-iae-zero-length-span", call=lambda: metrics.iae([0.0, 0.0, 0.0], [1.0, 2.0, 3.0]),
         exc=ConfigurationError, names="zero length"),
    Case(id="metrics-iae-start-equals-until", call=lambda: metrics.iae([0, 1, 2.0], [1, 1, 1.0], start=1, until=1),
         exc=ConfigurationError, names="start=1.0 s to until=1.0 s has zero length"),
    Case(id="metrics-iae-unknown-signal", call=lambda: metrics.iae(TABLE, "nope"), exc=UnknownSignalError,
         names="'nope'"),
    Case(id="metrics-iae-unknown-signal-is-a-keyerror", call=lambda: metrics.iae(TABLE, "nope"), exc=KeyError,
         names="['p.y']"),
    Case(id="metrics-iae-unknown-wide-column", call=lambda: metrics.iae(pd.DataFrame({"y": [1.0]}), "nope"),
         exc=UnknownSignalError, names="['y']"),
    Case(id="metrics-quadratic-cost-unknown-signal", call=lambda: metrics.quadratic_cost(TABLE, ["nope"]),
         exc=UnknownSignalError, names="'nope'"),
    Case(id="metrics-iae-start-after-the-last-sample", call=lambda: metrics.iae([0, 1, 2.0], [1, 1, 1.0], start=5),
         exc=ConfigurationError, names="last sample at t=2.0 s"),
]
