"""A Jitterbug timing model: the stationary cost of random delays and dropouts, exactly.

Jitterbug (B. Lincoln and A. Cervin, "Jitterbug: a tool for analysis of real-time
control performance", IEEE CDC 2002; the Jitterbug manual, Lund 2002) describes *when*
the discrete systems of a model execute by a Markov chain of **timing nodes**:

* the model is built with ``TimingModel(model, delta, period)`` (Jitterbug's
  ``initjitterbug(delta, h)``): ``delta`` is the time grain (s), every delay lies on the
  grid ``0, delta, 2 delta, ...``; ``period`` (s, a multiple of delta) makes the model
  *periodic*, None aperiodic;
* :meth:`TimingModel.add_node` (``addtimingnode``) adds a node: when the chain enters it,
  its discrete systems execute (``execute``, in that order: Jitterbug's ``adddiscsys`` with
  a node id); then a delay drawn from ``delay`` (the probabilities of 0, delta, 2 delta,
  ... seconds: Jitterbug's ``Ptau``) passes, and the chain moves to one of the nodes
  ``next`` with the probabilities ``probabilities``.  The first node added is node 1.
  In a periodic model node 1 is entered at t = 0: a node without successors waits for
  the end of the period (its delay must be 0) and the chain enters node 1 again at the
  next period's start, or the node named by its ``then`` (a *start node*: entered only at
  a period's start; this is how a period passes on what the timing remembers -- e.g. the
  state of a bursty channel, see :mod:`netcosim.lq.loss`);
  the delays of a path through the period may not exceed the period.  In an aperiodic
  model every node needs successors.

The chain is expanded into timing states -- (node, time since the period began) in a
periodic model, the nodes in an aperiodic one -- each transition carrying its
probability p and duration T.  With ``X_s = E[z z^T 1{state = s}]`` (the total state's
second moment when the chain enters s, before s's executions), ``pi_s`` the stationary
probability of s and ``(E_s, W_s)`` the composed executions of s, the mean-square
iteration of the Markov jump linear system is::

    Y_s  = E_s X_s E_s^T + pi_s W_s
    X_t <- sum over transitions s -> t (p, T) of  p (Phi(T) Y_s Phi(T)^T + pi_s R(T))

to its fixed point; then the cost per unit time is (renewal reward)::

    J = sum_(s -> t, p, T)  p (tr(Q(T) Y_s) + pi_s J_noise(T))  /  sum_(s -> t, p, T) pi_s p T

with Phi, R, Q, J_noise the exact interval matrices of :mod:`netcosim.lq.integrals`.
**How the fixed point is found** (``method``): ``"solve"`` writes the iteration as one
linear map on the stacked ``vec X_s`` (S N^2 unknowns, N the total state's size), takes
its spectral radius from its eigenvalues (mean-square stable iff < 1) and solves the
linear equation directly; ``"iterate"`` runs the iteration from X = 0 and stops when the
largest change of an X_s (Frobenius norm) is at most ``tol`` times the largest X_s (if X
is no longer finite, exceeds ``1e100``, or has not converged after ``max_iterations``,
the loop is taken as not mean-square stable, with the spectral radius estimated from the
last iterations' changes); ``"auto"`` (default) solves when S N^2 <= 1500 and iterates
otherwise.  **Not mean-square stable**: the cost is ``inf``, ``stable`` is False and the
note says why.
The mean of z is taken as zero (the stationary mean of a stable model without
deterministic inputs).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any, Hashable, Iterable

import numpy as np

from .. import validate
from ..errors import ConfigurationError
from .matrices import show
from .propagation import Propagator
from .result import StationaryCost
from .systems import Interconnection

__all__ = ["TimingModel"]

#: a delay distribution must sum to 1 within this
PMF_TOLERANCE = 1e-9
#: X beyond this: diverged
DIVERGED = 1e100
#: method="auto" solves directly up to this many unknowns (S N^2), iterates beyond
SOLVE_LIMIT = 1500


@dataclass(frozen=True)
class _Node:
    key: Hashable
    delay: np.ndarray
    next: tuple[Hashable, ...]
    probabilities: np.ndarray
    execute: tuple[Hashable, ...]
    then: Hashable = None


class TimingModel:
    """When the discrete systems of *model* execute: a Markov chain of timing nodes.

    ``delta``: time grain (s, > 0); ``period``: the period (s, a multiple of delta) of a
    periodic model, None for an aperiodic one.  See the module for the semantics.

    Raises
    ------
    ConfigurationTypeError
        ``delta`` or ``period`` is not a number.
    ConfigurationError
        ``delta`` or ``period`` is not a positive finite number of seconds, or ``period``
        is not a whole multiple of ``delta``.

    Examples
    --------
    An integrator ``dx = u dt + dv`` (noise intensity r = 1, cost rate ``x^2``) sampled
    every h = 0.1 s under the deadbeat gain ``u = -x / h``, whose controller is dropped with
    probability p = 0.2 (then the actuator holds the last control): node 1 samples and
    moves on to node 2 (the controller executes) or to node 3 (nothing executes).  Solving
    the jump system's second moments by hand gives
    ``J = r h ((1 + 2p) / (3 (1 - 3p)) + 1/2)``: ``5 r h / 6`` without drops, twice that at
    p = 0.2, and no mean-square stability from p = 1/3 on.

    >>> import numpy as np
    >>> from netcosim import lq
    >>> h, p = 0.1, 0.2
    >>> loop = (lq.Interconnection()
    ...         .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=1.0, Q_c=np.diag([1.0, 0.0])),
    ...              inputs="ctrl")
    ...         .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
    ...         .add("ctrl", lq.DiscreteSystem.gain(-1 / h), inputs="sampler"))
    >>> timing = (lq.TimingModel(loop, delta=h, period=h)
    ...           .add_node(1, execute="sampler", next=[2, 3], probabilities=[1 - p, p])
    ...           .add_node(2, execute="ctrl")
    ...           .add_node(3))
    >>> cost = timing.cost()
    >>> cost.stable, round(cost.cost_rate, 6), round(h * ((1 + 2 * p) / (3 * (1 - 3 * p)) + 0.5), 6)
    (True, 0.166667, 0.166667)
    """

    def __init__(self, model: Interconnection, delta: float, period: float | None = None):
        self.model = model
        self.delta = validate.positive(delta, "TimingModel: delta", kind="a positive number of seconds")
        self.period_steps: int | None = None
        self.period: float | None = None    # as given: period_steps * delta may differ in the last bit
        if period is not None:
            h = validate.positive(period, "TimingModel: period", kind="a positive number of seconds")
            k = round(h / self.delta)
            if k < 1 or abs(h / self.delta - k) > 1e-9 * max(1, k):
                raise ConfigurationError(f"TimingModel: period must be a whole multiple of delta "
                                         f"{self.delta!r} s, got {period!r}")
            self.period_steps = k
            self.period = float(h)
        self.nodes: dict[Hashable, _Node] = {}

    def add_node(self, key: Hashable, delay: Any = (1.0,), next: Any = (), probabilities: Any = None,
                 execute: Any = (), then: Hashable = None) -> "TimingModel":
        """Add timing node *key* (Jitterbug's ``addtimingnode``); returns self.

        ``delay``: probabilities of a delay of 0, delta, 2 delta, ... seconds before the next
        node (sums to 1; default: no delay).  ``next``: the next node(s); ``probabilities``:
        of each (default: equal).  ``execute``: the discrete system(s) executed on entry.
        ``then`` (periodic models, nodes without ``next`` only): the start node of the next
        period (default: node 1).
        """
        if key in self.nodes:
            raise ConfigurationError(f"TimingModel.add_node: node {key!r} is already defined")
        what = f"TimingModel node {key!r}"
        pmf = np.array(delay, dtype=float).reshape(-1) if not isinstance(delay, str) else None
        if pmf is None or pmf.size == 0 or not np.all(np.isfinite(pmf)) or np.any(pmf < 0) \
                or abs(pmf.sum() - 1.0) > PMF_TOLERANCE:
            raise ConfigurationError(f"{what}: delay must be probabilities (>= 0, summing to 1) of the delays "
                                     f"0, delta, 2 delta, ..., got {show(delay)}")
        nxt = _keys(next)
        if probabilities is None:
            prob = np.full(len(nxt), 1.0 / len(nxt)) if nxt else np.zeros(0)
        else:
            prob = np.array(probabilities, dtype=float).reshape(-1)
            if prob.size != len(nxt) or not np.all(np.isfinite(prob)) or np.any(prob < 0) \
                    or (nxt and abs(prob.sum() - 1.0) > PMF_TOLERANCE):
                raise ConfigurationError(f"{what}: probabilities must be one per next node {list(nxt)}, "
                                         f">= 0 and summing to 1, got {show(probabilities)}")
        exe = _keys(execute)
        for k in exe:
            self.model.update_of(k)     # names a discrete system, or raises
        if then is not None and (nxt or self.period_steps is None):
            raise ConfigurationError(f"{what}: then= names the next period's start node; it is for nodes "
                                     f"without next node in a periodic model, got then={then!r}")
        self.nodes[key] = _Node(key, pmf / pmf.sum(), nxt, prob / prob.sum() if nxt else prob, exe, then)
        return self

    # --- the expanded chain -------------------------------------------------------------

    def transitions(self) -> tuple[list[tuple[Hashable, int]], list[tuple[int, int, float, float]]]:
        """The timing states (node, grid steps since the period began; 0 if aperiodic)
        reachable from node 1, and the transitions ``(from, to, probability, duration s)``."""
        if not self.nodes:
            raise ConfigurationError("TimingModel: no timing node was added")
        first = next(iter(self.nodes))
        H = self.period_steps
        starts = {first} | {n.then for n in self.nodes.values() if n.then is not None}
        states: list[tuple[Hashable, int]] = [(first, 0)]
        index = {states[0]: 0}
        trans: list[tuple[int, int, float, float]] = []
        todo = deque([0])

        def target(state: tuple[Hashable, int]) -> int:
            if state not in index:
                index[state] = len(states)
                states.append(state)
                todo.append(index[state])
            return index[state]

        while todo:
            s = todo.popleft()
            key, k = states[s]
            node = self.nodes[key]
            if not node.next:
                if H is None:
                    raise ConfigurationError(f"TimingModel node {key!r} has no next node (an aperiodic model "
                                             f"needs one for every node)")
                if node.delay.size > 1 and np.any(node.delay[1:] > 0):
                    raise ConfigurationError(f"TimingModel node {key!r}: a node without next node waits for "
                                             f"the period's end; its delay must be 0, got {show(node.delay)}")
                then = first if node.then is None else node.then
                if then not in self.nodes:
                    raise ConfigurationError(f"TimingModel node {key!r}: then node {then!r} is not defined")
                trans.append((s, target((then, 0)), 1.0, (H - k) * self.delta))
                continue
            for j in node.next:
                if j not in self.nodes:
                    raise ConfigurationError(f"TimingModel node {key!r}: next node {j!r} is not defined")
                if H is not None and j in starts:
                    raise ConfigurationError(f"TimingModel node {key!r}: in a periodic model the start node "
                                             f"{j!r} is entered by the period only, not as a next node")
            for d in np.flatnonzero(node.delay):
                kd = k + int(d) if H is not None else 0
                if H is not None and kd > H:
                    raise ConfigurationError(f"TimingModel node {key!r}: a delay of {int(d)} grain(s) after "
                                             f"{k} reaches past the period of {H} grains")
                for j, q in zip(node.next, node.probabilities):
                    if q > 0:
                        trans.append((s, target((j, kd)), float(node.delay[d] * q), int(d) * self.delta))
        return states, trans

    def cost(self, *, method: str = "auto", tol: float = 1e-14, max_iterations: int = 100_000) -> StationaryCost:
        """The stationary cost per second (Jitterbug's ``calccost``; see the module for
        ``method``, and ``tol`` and ``max_iterations`` of the iteration)."""
        validate.choice(method, "TimingModel.cost: method", ("auto", "solve", "iterate"))
        tol = validate.positive(tol, "TimingModel.cost: tol")
        max_iterations = validate.count(max_iterations, "TimingModel.cost: max_iterations", minimum=1)
        states, trans = self.transitions()
        S = len(states)
        prop = Propagator(self.model, record=False)
        N = prop.dynamics.size
        pi = _stationary_distribution(S, trans)
        upd = []
        for key, _ in states:
            E, W = np.eye(N), np.zeros((N, N))
            for k in self.nodes[key].execute:
                Ek, Wk = self.model.update_of(k)
                E, W = Ek @ E, Ek @ W @ Ek.T + Wk
            upd.append((E, W))
        mats = [prop.matrices(T) for (_, _, _, T) in trans]
        const = [np.zeros((N, N)) for _ in range(S)]
        for (s, t, p, _), M in zip(trans, mats):
            const[t] += p * pi[s] * (M.Phi @ upd[s][1] @ M.Phi.T + M.R)
        if method == "solve" or (method == "auto" and S * N * N <= SOLVE_LIMIT):
            X, rho, it, note = _solve(S, N, trans, mats, upd, const)
        else:
            X, rho, it, note = _iterate(S, N, trans, mats, upd, const, tol, max_iterations)
        if note:
            return StationaryCost(math.inf, math.nan if self.period is None else self.period,
                                  False, rho, iterations=it,
                                  note=note + f" (mean-square spectral radius {rho:.6g}): "
                                              f"the loop is not mean-square stable under this timing")
        J = 0.0
        time = 0.0
        for (s, t, p, T), M in zip(trans, mats):
            Y = upd[s][0] @ X[s] @ upd[s][0].T + pi[s] * upd[s][1]
            J += p * (float(np.sum(M.Q * Y)) + pi[s] * M.J_noise)
            time += pi[s] * p * T
        if not time > 0.0:
            raise ConfigurationError("TimingModel: time never passes in this timing model (every delay is 0)")
        if self.period is not None:
            cycle = self.period
        else:
            first = states[0][0]
            cycle = time / float(sum(pi[s] for s in range(S) if states[s][0] == first))
        conditional = {states[s]: X[s] / pi[s] if pi[s] > 0 else X[s] for s in range(S)}
        return StationaryCost(float(J / time), float(cycle), True, rho, covariance=conditional, iterations=it)


def _solve(S, N, trans, mats, upd, const):
    """The fixed point as one linear equation; the spectral radius from its eigenvalues."""
    n = N * N
    L = np.zeros((S * n, S * n))
    for (s, t, p, _), M in zip(trans, mats):
        A = M.Phi @ upd[s][0]
        L[t * n:(t + 1) * n, s * n:(s + 1) * n] += p * np.kron(A, A)
    with np.errstate(over="ignore", invalid="ignore"):
        rho = float(np.max(np.abs(np.linalg.eigvals(L)))) if L.size else 0.0
    if not rho < 1.0:
        return None, rho, 0, "the spectral radius of the second-moment map is not below 1"
    x = np.linalg.solve(np.eye(S * n) - L, np.concatenate([c.reshape(-1) for c in const]))
    X = [0.5 * (b + b.T) for b in x.reshape(S, N, N)]
    return X, rho, 0, ""


def _iterate(S, N, trans, mats, upd, const, tol, max_iterations):
    """The fixed point by iteration from zero; the spectral radius from its changes."""
    X = [np.zeros((N, N)) for _ in range(S)]
    changes: deque[float] = deque(maxlen=20)
    note, it = "", 0
    for it in range(1, max_iterations + 1):
        Xn = [c.copy() for c in const]
        for (s, t, p, _), M in zip(trans, mats):
            EX = upd[s][0] @ X[s] @ upd[s][0].T
            Xn[t] += p * (M.Phi @ EX @ M.Phi.T)
        with np.errstate(over="ignore", invalid="ignore"):
            change = max(float(np.linalg.norm(a - b)) for a, b in zip(Xn, X))
            size = max(float(np.linalg.norm(a)) for a in Xn)
        changes.append(change)
        X = Xn
        if not math.isfinite(size) or size > DIVERGED:
            note = f"the covariance grew beyond {DIVERGED:g} after {it} iterations"
            break
        if change <= tol * size:
            return X, _rate(changes), it, ""
    return X, _rate(changes), it, note or f"no convergence to {tol:g} in {max_iterations} iterations"


def _keys(value: Any) -> tuple[Hashable, ...]:
    if value is None:
        return ()
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        return (value,)
    return tuple(value)


def _stationary_distribution(S: int, trans: list[tuple[int, int, float, float]]) -> np.ndarray:
    """The stationary probabilities of the timing states (the chain is irreducible on the
    states reachable from node 1 when every path returns there)."""
    P = np.zeros((S, S))
    for s, t, p, _ in trans:
        P[s, t] += p
    A = np.vstack([P.T - np.eye(S), np.ones((1, S))])
    b = np.zeros(S + 1)
    b[-1] = 1.0
    pi, *_ = np.linalg.lstsq(A, b, rcond=None)
    if np.max(np.abs(A @ pi - b)) > 1e-9:
        raise ConfigurationError("TimingModel: the timing chain has no unique stationary distribution "
                                 "(some timing states never return to node 1)")
    return np.clip(pi, 0.0, None)


def _rate(changes: Iterable[float]) -> float:
    """The geometric rate of the last changes (an estimate of the spectral radius)."""
    c = [x for x in changes if x > 0]
    if len(c) < 2:
        return 0.0
    return float((c[-1] / c[0]) ** (1.0 / (len(c) - 1)))
