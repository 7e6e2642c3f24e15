"""SciPy's ``solve_ivp`` as a plant integrator (the default one)."""

from __future__ import annotations

import math

import numpy as np

from .. import validate
from ..errors import ConfigurationError, IntegrationError
from .events import first_event, terminal_events
from .values import _check_count

__all__ = ["SOLVE_IVP_METHODS", "IMPLICIT_METHODS", "RTOL_MIN", "SolveIVP"]

#: The ``method`` names ``scipy.integrate.solve_ivp`` accepts (a subclass of
#: ``scipy.integrate.OdeSolver`` is accepted too).
SOLVE_IVP_METHODS = ("RK45", "RK23", "DOP853", "Radau", "BDF", "LSODA")

#: The implicit (stiff-capable) ones among them.
IMPLICIT_METHODS = ("Radau", "BDF", "LSODA")


class _BudgetExceeded(Exception):
    """Raised inside ``solve_ivp`` to stop it; turned into an IntegrationError."""


#: the smallest relative tolerance :class:`SolveIVP` accepts: SciPy's solvers raise a
#: smaller one to this (``100 * np.finfo(float).eps``)
RTOL_MIN = 100 * float(np.finfo(float).eps)


class SolveIVP:
    """SciPy ``solve_ivp`` with event location (the default integrator).

    Each lazy advance is one ``solve_ivp`` call from the last I/O instant to the next,
    stopped at the first event.

    Parameters
    ----------
    method: one of :data:`SOLVE_IVP_METHODS` or an ``OdeSolver`` subclass.

        * ``"RK45"`` (default), ``"DOP853"`` (tight tolerances), ``"RK23"``: explicit,
          cheap per step, for non-stiff plants.
        * ``"Radau"``, ``"BDF"``, ``"LSODA"``: implicit (LSODA switches
          automatically), for **stiff** plants, whose fastest modes (``|λ|`` of the
          Jacobian) are far faster than the sampling and than the dynamics of
          interest, e.g. λ = 10**6 1/s under 1 ms sampling.  An explicit method must
          then take steps of about ``1/|λ|`` whatever the tolerance (one simulated second
          at λ = 10**6 takes RK45 about 10**6 steps); an implicit one takes steps set by
          the accuracy only.  Each implicit step costs a Jacobian (``system.jac`` if the
          system defines it, else ``nx`` extra evaluations of ``f``) and a linear solve.
    rtol, atol: relative and absolute error tolerances (finite, > 0), per state, in
        the state's units; ``rtol`` from :data:`RTOL_MIN` (100 machine epsilons, below
        which SciPy's solvers cannot go) to below 1.
    max_step: longest step in seconds (> 0, ``inf`` = no limit).
    max_evaluations: most evaluations of ``f`` one advance (one call of
        :meth:`integrate`) may use; beyond it the advance stops with
        :class:`~netcosim.errors.IntegrationError` suggesting an implicit method.
        Default 50 000 (about 8 000 RK45 steps).

    Raises
    ------
    ConfigurationError
        *method* is neither one of :data:`SOLVE_IVP_METHODS` nor an ``OdeSolver``
        subclass; *rtol*, *atol* or *max_step* is not a positive number (*max_step* may
        be ``inf``); *rtol* is below :data:`RTOL_MIN` or not below 1;
        *max_evaluations* is below 1.
    ConfigurationTypeError
        *max_evaluations* is not an integer.
    IntegrationError
        later, when an advance of the plant needs more than *max_evaluations*
        evaluations of ``f``, or ``solve_ivp`` fails.

    Examples
    --------
    The stiff lag ``dx/dt = -10**5 (x - u)`` (time constant 10 µs) under ``u = 1`` for
    1 s: Radau settles it in a few steps; RK45 needs steps of about 10 µs and runs out
    of its budget of evaluations:

    >>> from netcosim import Simulation
    >>> from netcosim.plant import ContinuousSystem, SolveIVP
    >>> stiff = ContinuousSystem(f=lambda t, x, u, p: -1e5 * (x - u), states=["x"], inputs=["u"],
    ...                          name="stiff")
    >>> sim = Simulation()
    >>> fast = sim.plant(stiff, [0.0], integrator=SolveIVP(method="Radau"))
    >>> fast.input("u").write(1.0)
    >>> sim.run(until=1.0)
    >>> round(float(fast.state[0]), 9)
    1.0
    >>> sim = Simulation()
    >>> slow = sim.plant(stiff, [0.0], integrator=SolveIVP(max_evaluations=5000))
    >>> slow.input("u").write(1.0)
    >>> sim.run(until=1.0)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
      ...
    netcosim.errors.IntegrationError: plant 'stiff': SolveIVP(method='RK45') used more than max_evaluations=5000 ...
    """

    def __init__(self, method: str = "RK45", rtol: float = 1e-8, atol: float = 1e-10,
                 max_step: float = math.inf, max_evaluations: int = 50_000):
        from scipy.integrate import OdeSolver
        if isinstance(method, type) and issubclass(method, OdeSolver):
            pass
        elif not isinstance(method, str) or method not in SOLVE_IVP_METHODS:
            raise ConfigurationError(f"SolveIVP method must be one of {list(SOLVE_IVP_METHODS)} "
                                     f"(or an OdeSolver subclass), got {method!r}")
        for nm, v in (("rtol", rtol), ("atol", atol), ("max_step", max_step)):
            validate.positive(v, f"SolveIVP {nm}", kind="a positive number", type_error=ConfigurationError,
                              allow_inf=nm == "max_step")
        if not RTOL_MIN <= rtol < 1.0:
            # SciPy would raise a smaller rtol to 100 * eps with a warning at the first step
            raise ConfigurationError(f"SolveIVP rtol must be at least {RTOL_MIN!r} (100 machine epsilons, the "
                                     f"smallest SciPy's solvers use) and below 1, got {rtol!r}")
        _check_count(max_evaluations, "SolveIVP max_evaluations")
        self.method, self.rtol, self.atol, self.max_step = method, rtol, atol, max_step
        self.max_evaluations = int(max_evaluations)

    def __repr__(self):
        m = self.method if isinstance(self.method, str) else self.method.__name__
        return f"SolveIVP(method={m!r})"

    def bind(self, plant) -> SolveIVP:
        """The integrator that advances *plant*: this one (``solve_ivp`` needs nothing of the plant
        but its right-hand side and Jacobian)."""
        return self

    @property
    def implicit(self) -> bool:
        """True for the stiff-capable methods (Radau, BDF, LSODA)."""
        return self.method in IMPLICIT_METHODS

    def t_eval(self, t0: float, t1: float):
        """Hook for subclasses: instants (s, increasing, in ``(t0, t1]``, ending with *t1*)
        at which one advance from *t0* to *t1* should also report the state through
        :meth:`observe` (from the solver's dense output: the steps do not change).  The
        default, None, reports nothing."""
        return None

    def observe(self, t, x) -> None:
        """Hook for subclasses: the states ``x`` (nx, k; in the states' units) at the
        instants ``t`` (k,; s) asked by :meth:`t_eval` (up to a terminal event)."""

    def integrate(self, rhs, t0, x0, t1, gs, jac=None, dense=None):
        """Integrate ``dx/dt = rhs(t, x)`` from ``(t0, x0)`` to *t1* (s) with :func:`scipy.integrate.solve_ivp`.

        The guards *gs* (pairs ``(g, direction)``) are terminal events; *jac* is the
        Jacobian of *rhs* for the implicit methods.  *dense* (optional) is a pair
        ``(times, report)``: *times* increasing instants (s) in ``(t0, t1]``, and
        ``report(t, x)`` receives those up to the end of this advance with the states
        there (x: nx by k) from the solver's dense output -- the steps, and so
        ``x_end``, are the same as without it.  Returns ``(t_end, x_end, index of the
        fired guard or None)``.
        """
        events = terminal_events(gs)
        budget = self.max_evaluations
        count = 0
        reached = [t0]

        def counted(t, x):
            nonlocal count
            count += 1
            if count > budget:
                raise _BudgetExceeded
            reached[0] = t
            return rhs(t, x)
        kw = {"jac": jac} if jac is not None and self.implicit else {}
        t_eval = self.t_eval(t0, t1)
        if t_eval is not None:
            kw["t_eval"] = t_eval
        if dense is not None:
            kw["dense_output"] = True
        try:
            from scipy.integrate import solve_ivp  # loaded on first use
            sol = solve_ivp(counted, (t0, t1), x0, method=self.method, rtol=self.rtol, atol=self.atol,
                            max_step=self.max_step, events=events or None, **kw)
        except _BudgetExceeded:
            hint = ("the plant is probably stiff (modes much faster than this interval): use "
                    "SolveIVP(method='Radau') or SolveIVP(method='BDF')" if not self.implicit else
                    "the plant may be very stiff or discontinuous")
            raise IntegrationError(
                f"{self!r} used more than max_evaluations={budget} evaluations of f advancing from "
                f"t={t0!r} to t={t1!r} s and got only to t={float(reached[0])!r} s; {hint}, "
                f"or raise max_evaluations") from None
        if sol.status == -1:
            raise IntegrationError(f"solve_ivp ({self!r}) failed between t={t0!r} and t={t1!r} s: "
                                   f"{sol.message}")
        if t_eval is not None:
            self.observe(sol.t, sol.y)
        if sol.status == 1:
            first = first_event(sol)
            if dense is not None:
                _report_dense(sol, dense, first[0])
            return first[0], np.asarray(first[2], dtype=float), first[1]
        if dense is not None:
            _report_dense(sol, dense, t1)
        return t1, sol.y[:, -1].copy(), None


def _report_dense(sol, dense, t_end: float) -> None:
    """Hand ``dense = (times, report)`` the states at the *times* up to *t_end* (s)."""
    times, report = dense
    ts = np.asarray(times, dtype=float)
    ts = ts[ts <= t_end]
    if ts.size and sol.sol is not None:
        report(ts, np.asarray(sol.sol(ts), dtype=float).reshape(-1, ts.size))
