"""Control cost metrics of a sampled run: IAE, ISE, ITAE, the quadratic cost J, the
settling time and a divergence flag.

Inputs
------
Every metric takes its signal in one of three forms:

* arrays ``(t, v)``: sample times in s (non-decreasing; repeated instants allowed) and
  the sampled values, e.g. ``iae(t, e)``;
* a pandas ``Series`` indexed by time (s), as ``sim.trace.signal(source, signal)``
  returns, e.g. ``iae(sim.trace.signal("servo", "y.y"), reference=1.0)``;
* a signals table and a signal name: the tidy table ``sim.trace.signals()`` (columns
  ``time, source, signal, value``) with the name ``"<source>.<signal>"`` (as in
  ``signals(wide=True)``, e.g. ``"servo.y.y"``), or that wide table (index ``time``)
  with a column name.

``reference`` (a number, or a function ``r(t)`` of time in s evaluated at the sample
instants) turns a measured output ``y`` into the error ``e = r - y``; without it the
signal is the error itself.

Integration rule
----------------
Signals are samples ``(t_k, v_k)``, possibly non-uniform.  ``hold`` says what the
signal is between samples, and each metric is the *exact* integral of that signal:

``"zoh"`` (default)
    zero-order hold: ``v(t) = v_k`` on ``[t_k, t_(k+1))`` -- what a sampled
    controller's output is, and the exact value for any piecewise-constant signal
    (e.g. ``IAE = sum |v_k| (t_(k+1) - t_k)``).
``"linear"``
    linear interpolation between samples; the integrals of the interpolated signal are
    computed in closed form (zero crossings located exactly for IAE/ITAE, quadratic
    forms integrated exactly for ISE/J), so they differ from the trapezoidal rule where
    the signal changes sign or curvature matters.

Approximating a smooth signal by its samples costs O(h) with ``"zoh"`` and O(h^2) with
``"linear"`` (h the sample spacing); the tests derive their tolerances from that.

The window is ``[start, until]`` (s): ``start`` defaults to the first sample, ``until``
to the last one; beyond the last sample the last value is held.  ITAE weighs the error
by the time elapsed since ``start``.

Which grid
----------
A metric is only as good as its samples, so every result is a :class:`Cost`: a
``float`` that also carries ``grid``, a sentence naming the samples it integrated
(how the source was logged, when known, then how many samples on which window and
their spacing), and ``times``, those instants (s).  A plant is logged at the
instants tasks read and write it, on ``log_interval`` if given, and on the default
grid (:data:`netcosim.plant.DEFAULT_LOG_INTERVAL`, 1 ms) until a task first
touches it, so a starved loop (its controller never runs) still has a cost: the
open-loop trajectory on that grid.

Conventions
-----------
``J = integral of x'Qx + u'Ru + 2 x'Nu dt`` is the cost of python-control's
``lqr(A, B, Q, R, N)`` (so for the LQR loop ``J = x0' S x0``, a test checks it) and the
continuous cost of Jitterbug (Lincoln and Cervin) with the weight
``[[Q, N], [N', R]]``, which must be symmetric positive semidefinite.  Jitterbug reports
the stationary *average* ``J/T``; divide by the window length for that.

Why this module: python-control computes optimal costs (``lqr``, ``care``) and
``step_info`` (settling time of a step response relative to its final value, sample by
sample) but has no integral criteria of sampled data, no non-uniform sampling and no
choice of hold; :func:`settling_time` follows ``step_info``'s definition for
``hold="zoh"`` (a test compares them) and extends it to errors that settle to 0.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Sequence

import numpy as np

from . import validate
from .errors import ConfigurationError, ConfigurationTypeError, IntegrationError
from .sampled import _error, _no_nan, _settling, _split_at_zeros, _tidy_names, _times, _unknown, _values, _window

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["HOLDS", "DIVERGENCE_ERRORS", "Cost", "iae", "ise", "itae", "quadratic_cost", "settling_time",
           "diverged", "samples"]

#: The ways a sampled signal is completed between samples (see the module docstring).
HOLDS = ("zoh", "linear")

#: Exceptions of a run that mean its state blew up (:func:`diverged` counts them).
DIVERGENCE_ERRORS: tuple[type[BaseException], ...] = (FloatingPointError, OverflowError, IntegrationError)

_TIDY = ("time", "source", "signal", "value")


class Cost(float):
    """The value of a metric (a ``float``, in the metric's unit) that says which samples
    it was computed from.

    ``grid``: a sentence: how the signal's source is logged (``Trace.grids``, when the
    signal came from a trace and its source said), then the number of samples
    integrated, the window and their spacing, e.g. ``"default grid 1 ms until the first
    read or write, then read/write instants; 1001 samples on [0, 1] s, every 1 ms"``.
    ``times``: the sample instants integrated (s), window ends included.  Arithmetic on
    a Cost gives plain floats; ``float(cost)`` drops the rest.

    Examples
    --------
    The ISE of a first-order lag's step response, logged every 10 ms: the cost says
    which samples it integrated (the run stops at 1 s, so the last row is at 0.99 s):

    >>> from netcosim import Simulation, metrics
    >>> from netcosim.plant import ContinuousSystem
    >>> lag = ContinuousSystem(f=lambda t, x, u, p: -x + u, states=["x"], inputs=["u"], name="lag")
    >>> sim = Simulation()
    >>> plant = sim.plant(lag, [0.0], log_interval=0.01)
    >>> plant.input("u").write(1.0)
    >>> sim.run(until=1.0)
    >>> cost = metrics.ise(sim.trace.signal("lag", "y.x"), reference=1.0)
    >>> round(cost, 4)
    0.4353
    >>> cost.grid
    'lag: log_interval 10 ms; 100 samples on [0, 0.99] s, every 10 ms'
    >>> cost.times[:3].tolist(), type(cost * 2).__name__
    ([0.0, 0.01, 0.02], 'float')
    """

    grid: str
    times: np.ndarray

    def __new__(cls, value: float, grid: str = "", times: Any = ()) -> "Cost":
        self = super().__new__(cls, value)
        self.grid = grid
        self.times = np.asarray(times, dtype=float)
        return self

    def __reduce__(self):
        return (Cost, (float(self), self.grid, self.times))


def _seconds(x: float) -> str:
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9)):
        if abs(x) >= scale:
            return f"{x / scale:.6g} {unit}"
    return f"{x:.6g} s"


def _grid_text(t: np.ndarray, rule: str | None) -> str:
    """``grid`` of a :class:`Cost` integrated over the instants *t* (s)."""
    t = np.asarray(t, dtype=float)
    h = np.diff(t)
    h = h[h > 0]
    if not h.size:
        spacing = "no spacing"
    elif float(h.max() - h.min()) <= 1e-9 * float(h.max()):
        spacing = f"every {_seconds(float(h.max()))}"
    else:
        spacing = f"spacing {_seconds(float(h.min()))} to {_seconds(float(h.max()))}"
    text = f"{t.size} samples on [{t[0]:.6g}, {t[-1]:.6g}] s, {spacing}"
    return f"{rule}; {text}" if rule else text


def _rule(data: Any, signal: Any) -> str | None:
    """How the source of the signal is logged, when the data says (``Trace.grids``)."""
    attrs = getattr(data, "attrs", None)
    if not isinstance(attrs, dict):
        return None
    if isinstance(attrs.get("grid"), str):
        return attrs["grid"]
    grids = attrs.get("grids")
    if isinstance(grids, dict) and isinstance(signal, str):
        for source in sorted(grids, key=len, reverse=True):
            if signal.startswith(f"{source}."):
                return f"{source}: {grids[source]}"
    return None


def _cost(value: float, t: np.ndarray, data: Any, signal: Any) -> Cost:
    return Cost(value, _grid_text(t, _rule(data, signal)), t)


# ---------------------------------------------------------------------- input handling
def _check_hold(hold: str) -> str:
    return validate.choice(hold, "hold", HOLDS)


def samples(data: Any, signal: Any = None, *, what: str = "signal") -> tuple[np.ndarray, np.ndarray]:
    """The samples ``(t, v)`` (times in s, values) of one signal given in any accepted form.

    *data*: sample times (then *signal* holds the values), a ``Series`` indexed by time
    (s), or a signals table -- tidy (``time, source, signal, value``; *signal* is
    ``"<source>.<signal>"``) or wide (index time; *signal* is a column).  Times are
    checked to be finite and sorted; values are returned as they are, NaN included (the
    integral criteria refuse a NaN, naming the first one; :func:`settling_time` reads it
    as not settled).  *what* names the caller in errors (e.g. ``"settling_time"``).

    Raises
    ------
    ConfigurationTypeError
        a ``Series`` with a *signal* as well; a table with a *signal* that is not a
        string; sample times without values; times or values that are not numbers.
    ConfigurationError
        times that are not one-dimensional, empty, not finite or not sorted; values of
        another shape or length than the times.
    UnknownSignalError
        (:class:`netcosim.trace.UnknownSignalError`, a ``KeyError``) a name not in the
        table; the message lists the names that are.

    Examples
    --------
    The step response of the lag ``dx/dt = -x + u`` (``y = x``), logged every 250 ms,
    is ``1 - e^-t``; the same samples from the tidy table and from a ``Series``:

    >>> from netcosim import Simulation, metrics
    >>> from netcosim.plant import ContinuousSystem
    >>> lag = ContinuousSystem(f=lambda t, x, u, p: -x + u, states=["x"], inputs=["u"], name="lag")
    >>> sim = Simulation()
    >>> plant = sim.plant(lag, [0.0], log_interval=0.25)
    >>> plant.input("u").write(1.0)
    >>> sim.run(until=1.0)
    >>> t, y = metrics.samples(sim.trace.signals(), "lag.y.x")
    >>> t.tolist(), y.round(6).tolist()
    ([0.0, 0.25, 0.5, 0.75], [0.0, 0.221199, 0.393469, 0.527633])
    >>> metrics.samples(sim.trace.signal("lag", "y.x"))[1].round(6).tolist()
    [0.0, 0.221199, 0.393469, 0.527633]
    >>> metrics.samples(sim.trace.signals(), "lag.y")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
      ...
    netcosim.trace.UnknownSignalError: signal: no signal 'lag.y' in the table; it holds ['lag.u.u', 'lag.x.x', ...]
    """
    import pandas as pd

    if isinstance(data, pd.Series):
        if signal is not None:
            raise ConfigurationTypeError(f"{what}: a Series carries its own values; got signal={signal!r} too")
        t = _times(data.index.to_numpy(), what)
        return t, _values(data.to_numpy(), t.size, what)
    if isinstance(data, pd.DataFrame):
        if not isinstance(signal, str):
            raise ConfigurationTypeError(f"{what}: with a signals table, name the signal as a string "
                                         f"('<source>.<signal>'), got {signal!r}")
        if all(c in data.columns for c in _TIDY):
            names = _tidy_names(data)
            sel = names == signal
            if not sel.any():
                raise _unknown(f"{what}: no signal {signal!r} in the table; it holds {sorted(set(names))}")
            part = data.loc[sel]
            t = _times(part["time"].to_numpy(), f"{what} {signal!r}")
            return t, _values(part["value"].to_numpy(), t.size, what)
        if signal not in data.columns:
            raise _unknown(f"{what}: no column {signal!r} in the table; it has {list(data.columns)}")
        col = data[signal].dropna()
        t = _times(col.index.to_numpy(), f"{what} {signal!r}")
        return t, _values(col.to_numpy(), t.size, what)
    if signal is None:
        raise ConfigurationTypeError(f"{what}: give sample times and values (t, v), a Series indexed by time or "
                                     f"a signals table and a name; got {type(data).__name__} alone")
    t = _times(data, what)
    return t, _values(signal, t.size, what)


def _prepare(data, signal, reference, start, until, hold, what):
    hold = _check_hold(hold)
    t, v = samples(data, signal, what=what)
    _no_nan(t, v, what)
    return (*_window(t, _error(t, v, reference), start, until, hold), hold)


# ---------------------------------------------------------------------- integral criteria
def iae(data: Any, signal: Any = None, *, reference: Any = None, start: float | None = None,
        until: float | None = None, hold: str = "zoh") -> Cost:
    """Integral of the absolute error ``IAE = integral of |e(t)| dt`` over ``[start, until]`` (s).

    *data*, *signal*: the samples (times in s), in any form of :func:`samples`;
    ``reference``: a number or ``r(t)`` (t in s) making the error ``r - y``; ``hold``:
    ``"zoh"`` or ``"linear"`` (the integral is exact for the held or interpolated signal).
    Result in (signal unit) x s, a :class:`Cost` (its ``grid`` names the samples used).

    Examples
    --------
    Held samples (zero-order hold): ``|1| * 1 s + |-0.5| * 1 s``.

    >>> from netcosim import metrics
    >>> float(metrics.iae([0.0, 1.0, 2.0], [1.0, -0.5, 0.0]))
    1.5
    """
    t, e, _, hold = _prepare(data, signal, reference, start, until, hold, "iae")
    if hold == "zoh":
        return _cost(float(np.sum(np.abs(e[:-1]) * np.diff(t))), t, data, signal)
    used = t
    t, e = _split_at_zeros(t, e)
    a = np.abs(e)
    return _cost(float(np.sum((a[:-1] + a[1:]) * np.diff(t)) / 2), used, data, signal)


def ise(data: Any, signal: Any = None, *, reference: Any = None, start: float | None = None,
        until: float | None = None, hold: str = "zoh") -> Cost:
    """Integral of the squared error ``ISE = integral of e(t)^2 dt`` over ``[start, until]`` (s).

    Arguments as :func:`iae` (*data*, *signal*: the samples; ``reference``: a number or
    ``r(t)``, the error ``r - y``, None: the signal itself); with ``hold="linear"`` each segment contributes exactly
    ``h (a^2 + a b + b^2) / 3``.  Result in (signal unit)^2 x s.

    Examples
    --------
    ``e(t) = e^-t`` sampled every 10 ms on [0, 1] s: the exact ISE is
    ``(1 - e^-2) / 2``; the held samples overestimate it by O(h), the interpolated ones
    are off by O(h^2):

    >>> import math
    >>> import numpy as np
    >>> from netcosim import metrics
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> round(metrics.ise(t, np.exp(-t)), 6), round(metrics.ise(t, np.exp(-t), hold="linear"), 6)
    (0.43667, 0.43234)
    >>> round((1 - math.exp(-2)) / 2, 6)
    0.432332
    """
    t, e, _, hold = _prepare(data, signal, reference, start, until, hold, "ise")
    h = np.diff(t)
    a, b = e[:-1], e[1:]
    if hold == "zoh":
        return _cost(float(np.sum(a * a * h)), t, data, signal)
    return _cost(float(np.sum((a * a + a * b + b * b) * h) / 3), t, data, signal)


def itae(data: Any, signal: Any = None, *, reference: Any = None, start: float | None = None,
         until: float | None = None, hold: str = "zoh") -> Cost:
    """Integral of time-weighted absolute error ``ITAE = integral of (t - start) |e(t)| dt``
    over ``[start, until]`` (s).

    Arguments as :func:`iae` (*data*, *signal*: the samples; ``reference``: a number or
    ``r(t)``, the error ``r - y``, None: the signal itself; ``hold``: ``"zoh"`` or
    ``"linear"``, exact for the held or interpolated error).  The weight is the time since ``start`` (default the first
    sample), so a run logged from t = 0 gets the textbook ``integral of t |e| dt``.
    Result in (signal unit) x s^2.

    Examples
    --------
    ``e(t) = e^-t`` sampled every 10 ms on [0, 1] s: the exact ITAE is
    ``integral of t e^-t dt = 1 - 2/e``:

    >>> import math
    >>> import numpy as np
    >>> from netcosim import metrics
    >>> t = np.linspace(0.0, 1.0, 101)
    >>> round(metrics.itae(t, np.exp(-t)), 6), round(metrics.itae(t, np.exp(-t), hold="linear"), 6)
    (0.26557, 0.264243)
    >>> round(1 - 2 / math.e, 6)
    0.264241
    """
    t, e, s, hold = _prepare(data, signal, reference, start, until, hold, "itae")
    tau = t - s
    if hold == "zoh":
        return _cost(float(np.sum(np.abs(e[:-1]) * (tau[1:] ** 2 - tau[:-1] ** 2)) / 2), t, data, signal)
    tau, e = _split_at_zeros(tau, e)
    a, b, h, t0 = np.abs(e[:-1]), np.abs(e[1:]), np.diff(tau), tau[:-1]
    return _cost(float(np.sum(h * t0 * (a + b) / 2 + h * h * (a + 2 * b) / 6)), t, data, signal)


# ---------------------------------------------------------------------- quadratic cost
def _weight(m: Any, n: int, name: str) -> np.ndarray:
    try:
        w = np.atleast_2d(np.asarray(m, dtype=float))
    except (TypeError, ValueError):
        raise ConfigurationTypeError(f"quadratic_cost: {name} must be a matrix of numbers, got {m!r}") from None
    if w.shape != (n, n):
        raise ConfigurationError(f"quadratic_cost: {name} must be {n} x {n}, got shape {w.shape}: {m!r}")
    if not np.all(np.isfinite(w)):
        raise ConfigurationError(f"quadratic_cost: {name} must be finite, got {m!r}")
    if not np.allclose(w, w.T, rtol=1e-12, atol=1e-12 * max(1.0, float(np.abs(w).max()))):
        raise ConfigurationError(f"quadratic_cost: {name} must be symmetric, got {m!r}")
    return w


def _psd(w: np.ndarray, name: str, value: Any) -> None:
    lam = float(np.linalg.eigvalsh(w).min()) if w.size else 0.0
    if lam < -1e-10 * max(1.0, float(np.abs(w).max())):
        raise ConfigurationError(f"quadratic_cost: {name} must be positive semidefinite (smallest eigenvalue "
                                 f"{lam:.6g}), got {value!r}")


def _table_matrix(df: pd.DataFrame, names: Sequence[str], hold: str, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Several signals of a table on the union of their sample instants (from the latest
    first sample on), each held or interpolated there."""
    series = [samples(df, n, what=what) for n in names]
    first = max(t[0] for t, _ in series)
    grid = np.unique(np.concatenate([t[t >= first] for t, _ in series]))
    cols = []
    for t, v in series:
        if hold == "zoh":
            cols.append(v[np.searchsorted(t, grid, side="right") - 1])
        else:
            # the last of repeated instants wins, as with the hold
            last = np.r_[t[1:] != t[:-1], True]
            cols.append(np.interp(grid, t[last], v[last]))
    return grid, np.column_stack(cols)


def _names(x: Any, what: str) -> list[str]:
    if isinstance(x, str):
        return [x]
    if isinstance(x, (list, tuple)) and x and all(isinstance(n, str) for n in x):
        return list(x)
    raise ConfigurationTypeError(f"quadratic_cost: with a signals table, {what} must be a signal name or a list of "
                                 f"names, got {x!r}")


def quadratic_cost(data: Any, x: Any, u: Any = None, *, Q: Any = None, R: Any = None, N: Any = None,
                   start: float | None = None, until: float | None = None, hold: str = "zoh") -> Cost:
    """The quadratic cost ``J = integral of x'Qx + u'Ru + 2 x'Nu dt`` over ``[start, until]`` (s).

    *data*: the sample times (s) or a signals table.
    Arrays: ``quadratic_cost(t, x, u, Q=..., R=...)`` with sample times *t* (s), *x* of
    shape (samples,) or (samples, n) and *u* (optional) of shape (samples,) or
    (samples, m) on the same instants.  Signals table: ``quadratic_cost(table, ["servo.x.x0",
    ...], ["sensor.actuate.u"], ...)``; the signals are put on the union of their sample
    instants (from the latest first sample), each held or interpolated per ``hold``.

    ``Q`` (n x n), ``R`` (m x m), ``N`` (n x m): weights as in python-control's ``lqr``
    (defaults: identity, identity, zero); ``[[Q, N], [N', R]]`` must be symmetric
    positive semidefinite (a negative weight raises, naming it).  ``hold="zoh"`` sums
    ``z_k' W z_k (t_(k+1) - t_k)`` with ``z = [x; u]``; ``"linear"`` integrates the
    interpolated ``z`` exactly, ``h (a'Wa + a'Wb + b'Wb) / 3`` per segment.

    Raises
    ------
    ConfigurationTypeError
        the times, *x* or *u* are not numbers; with a signals table, *x* or *u* is not a
        signal name or a list of names; a weight is not a matrix of numbers; *start* or
        *until* is not a number (s).
    ConfigurationError
        *hold* is not ``"zoh"`` or ``"linear"``; the times are empty, not finite or not
        sorted; *x* or *u* has the wrong shape or length, or a NaN; *R* or *N* is given
        without *u*; a weight has the wrong shape, is not finite, not symmetric or not
        positive semidefinite (``[[Q, N], [N', R]]`` included); the window
        ``[start, until]`` is empty or outside the samples.
    UnknownSignalError
        (:class:`netcosim.trace.UnknownSignalError`, a ``KeyError``) a name not in the
        signals table.

    Examples
    --------
    The LQR loop of ``dx/dt = u`` with ``Q = R = 1`` is ``u = -x`` (the Riccati solution
    is ``S = 1``), so ``J = x0' S x0 = 1`` from ``x0 = 1``; here its trajectory
    ``x = e^-t``, ``u = -e^-t`` sampled every 10 ms over 10 s:

    >>> import numpy as np
    >>> from netcosim import metrics
    >>> t = np.linspace(0.0, 10.0, 1001)
    >>> x, u = np.exp(-t), -np.exp(-t)
    >>> round(metrics.quadratic_cost(t, x, u, Q=1.0, R=1.0, hold="linear"), 4)
    1.0
    >>> metrics.quadratic_cost(t, x, u, Q=-1.0)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
      ...
    netcosim.errors.ConfigurationError: quadratic_cost: Q must be positive semidefinite (smallest eigenvalue -1), ...
    """
    hold = _check_hold(hold)
    import pandas as pd

    if isinstance(data, pd.DataFrame):
        xn = _names(x, "x")
        un = [] if u is None else _names(u, "u")
        t, z = _table_matrix(data, xn + un, hold, "quadratic_cost")
        n, m = len(xn), len(un)
    else:
        t = _times(data, "quadratic_cost")
        xs = _values(x, t.size, "quadratic_cost: x", columns=True)
        parts = [xs]
        if u is not None:
            parts.append(_values(u, t.size, "quadratic_cost: u", columns=True))
        z = np.hstack(parts)
        n, m = xs.shape[1], z.shape[1] - xs.shape[1]
    _no_nan(t, z, "quadratic_cost")
    if R is not None and m == 0:
        raise ConfigurationError(f"quadratic_cost: R={R!r} given but no input signal u")
    if N is not None and m == 0:
        raise ConfigurationError(f"quadratic_cost: N={N!r} given but no input signal u")
    q = np.eye(n) if Q is None else _weight(Q, n, "Q")
    _psd(q, "Q", Q)
    w = np.zeros((n + m, n + m))
    w[:n, :n] = q
    if m:
        r = np.eye(m) if R is None else _weight(R, m, "R")
        _psd(r, "R", R)
        w[n:, n:] = r
        if N is not None:
            try:
                nn = np.asarray(N, dtype=float).reshape(n, m)
            except (TypeError, ValueError):
                raise ConfigurationError(f"quadratic_cost: N must be {n} x {m}, got {N!r}") from None
            w[:n, n:], w[n:, :n] = nn, nn.T
            _psd(w, "[[Q, N], [N', R]]", N)
    t, z, _ = _window(t, z, start, until, hold)
    h = np.diff(t)
    a, b = z[:-1], z[1:]
    qa = np.einsum("ki,ij,kj->k", a, w, a)
    rule = None
    if isinstance(data, pd.DataFrame):
        rules = sorted({r for r in (_rule(data, n) for n in xn + un) if r})
        rule = "; ".join(rules) or None
    if hold == "zoh":
        return Cost(float(np.sum(qa * h)), _grid_text(t, rule), t)
    qb = np.einsum("ki,ij,kj->k", b, w, b)
    qab = np.einsum("ki,ij,kj->k", a, w, b)
    return Cost(float(np.sum((qa + qab + qb) * h) / 3), _grid_text(t, rule), t)


# ---------------------------------------------------------------------- settling, divergence
def settling_time(data: Any, signal: Any = None, *, final: float | None = None, band: float = 0.02,
                  abs_band: float | None = None, start: float | None = None, hold: str = "zoh") -> Cost:
    """Time (s, counted from ``start``) after which the signal stays within the band
    around its final value, up to the last sample.  *data*, *signal*: the samples (times in
    s), in any form of :func:`samples`.

    The band is ``|y(t) - final| <= band * |final - y(start)|`` (a fraction of the step
    from the value at ``start`` to ``final``; 2 % by default), or ``|y(t) - final| <=
    abs_band`` (signal units) if ``abs_band`` is given.  ``final`` defaults to the last
    sample.  With ``hold="zoh"`` the answer is the first sample instant after the last
    sample outside the band (python-control's ``step_info`` ``SettlingTime`` for a step
    from 0); with ``"linear"`` it is the instant the interpolated signal crosses into
    the band.  0 if it never leaves the band; ``inf`` if the last sample is outside.

    Examples
    --------
    ``y = 1 - exp(-t/tau)`` with ``tau = 0.1`` s, sampled every 1 ms, settles to 2 % of
    its final value 1 at ``tau ln 50`` s:

    >>> import math
    >>> import numpy as np
    >>> from netcosim import metrics
    >>> t = np.linspace(0.0, 1.0, 1001)
    >>> y = 1 - np.exp(-t / 0.1)
    >>> float(metrics.settling_time(t, y, final=1.0)), round(metrics.settling_time(t, y, final=1.0, hold="linear"), 6)
    (0.392, 0.391203)
    >>> round(0.1 * math.log(50), 6)
    0.391202
    """
    hold = _check_hold(hold)
    t, y = samples(data, signal, what="settling_time")
    t, y, s = _window(t, y, start, None, hold)
    return _cost(_settling(t, y, s, final, band, abs_band, hold), t, data, signal)


def diverged(values: Any = None, bound: float = math.inf, *, error: BaseException | None = None) -> bool:
    """True if a run diverged: *error* is one of :data:`DIVERGENCE_ERRORS`
    (``FloatingPointError``, ``OverflowError``, :class:`~netcosim.errors.IntegrationError`),
    or *values* holds a NaN or an infinity, or a value with ``|v| > bound``.

    *values*: an array of any shape, a ``Series``, or a DataFrame (a tidy signals table:
    its ``value`` column; any other table: its numeric columns).  ``bound``: a positive
    number in the values' unit (default ``inf``: only non-finite values count).  An
    *error* of another kind is not divergence: the result then depends on *values* only.

    Raises
    ------
    ConfigurationTypeError
        *bound* is not a number, or *values* does not hold numbers.
    ConfigurationError
        *bound* is not positive (or is NaN).

    Examples
    --------
    >>> import math
    >>> from netcosim import metrics
    >>> from netcosim.errors import IntegrationError
    >>> metrics.diverged([0.5, -3.0]), metrics.diverged([0.5, -3.0], bound=2.5), metrics.diverged([0.5, math.nan])
    (False, True, True)
    >>> metrics.diverged(error=IntegrationError("state non-finite")), metrics.diverged(error=KeyError("y"))
    (True, False)
    """
    b = validate.real(bound, "diverged: bound", lo=0.0, lo_open=True, allow_inf=True,
                      kind="a positive number (or inf)")
    if error is not None and isinstance(error, DIVERGENCE_ERRORS):
        return True
    if values is None:
        return False
    import pandas as pd

    if isinstance(values, pd.DataFrame):
        values = values["value"] if "value" in values.columns else values.select_dtypes("number")
    try:
        arr = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise ConfigurationTypeError(f"diverged: values must be numbers, got {values!r}") from None
    if arr.size == 0:
        return False
    if not np.all(np.isfinite(arr)):
        return True
    return bool(np.abs(arr).max() > b)
