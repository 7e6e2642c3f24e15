"""The systems of a linear-quadratic model and their interconnection (JitterTime's model).

A model is a set of linear time-invariant systems, each named by a key (an int or a
string, JitterTime's *sysid*), whose inputs are the stacked outputs of other systems
(JitterTime's *inputid*: the input vector of a system is the concatenation of the output
vectors of the systems listed, in the order listed).  Two kinds:

:class:`ContinuousSystem` -- a plant, running all the time::

    dx = (A x + B u) dt + dv,     E[dv dv^T] = R_c dt,     y = C x

``R_c`` is the *intensity* of the white noise v (units of x^2 per second: over a short
interval dt the noise adds covariance R_c dt).  Its cost is the continuous-time integral
``∫ [x; u]^T Q_c [x; u] dt`` (units of the cost per second), where u is the system's
input as the connected outputs hold it.  The system is strictly proper (D = 0), as in
JitterTime: a direct term would make the input of one system an algebraic function of
another's, and the held outputs of the discrete systems are what the plants see.

:class:`DiscreteSystem` -- a sampler, a controller, an actuator (a hold): it changes only
when it is *executed* (JitterTime's ``execSys``, here :meth:`Propagator.update
<netcosim.lq.propagation.Propagator.update>`); its state x and its output y are both
held constant in between and are both part of the model's state::

    at an execution:  x+ = Phi x + Gamma u + e_x,    y+ = C x + D u + e_y,
                      E[[e_x; e_y] [e_x; e_y]^T] = R_d

(the output uses the state *before* the update and the input at that instant, the usual
``y(k) = C x(k) + D u(k)``).  ``R_d`` is a covariance (units of [x; y]^2) added at every
execution: on y it is the measurement noise of a sampler.  Its cost is, as in
JitterTime, a continuous-time weight on the held values, ``∫ [x; y]^T Q_c [x; y] dt``
(per second, like the plant's), not a charge per execution.  A static gain y = D u (a
sampler ``D = I``, a state feedback ``D = -L``) is :meth:`DiscreteSystem.gain`.

:class:`Interconnection` stacks the states into the *total state* z (the systems in the
order they were added; a discrete system contributes [x; y]) and builds, once,
JitterTime's ``calcDynamics``: the total continuous dynamics ``dz = A z dt + dv``
(intensity R_c), the total cost weight Q_c, and for each discrete system the map of an
execution ``z+ = E z + e``, ``E[e e^T] = W``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Hashable, Iterable

import numpy as np

from ..errors import ConfigurationError, ConfigurationTypeError
from .matrices import covariance, matrix, show, square

__all__ = ["ContinuousSystem", "DiscreteSystem", "Interconnection", "TotalDynamics"]


class ContinuousSystem:
    """A continuous-time LTI system driven by white noise, with a quadratic cost.

    ``A`` (n x n), ``B`` (n x r), ``C`` (p x n); ``D`` must be zero (or None) -- the system
    is strictly proper.  ``R_c``: intensity of the state noise (n x n, symmetric PSD,
    units x^2/s), None for none.  ``Q_c``: weight of the cost rate on [x; u]
    ((n + r) x (n + r), symmetric PSD), None for no cost.  Times are in seconds.

    Raises
    ------
    ConfigurationTypeError
        A matrix that is not numeric (a string, an object; None for ``A``, ``B`` or ``C``).
    ConfigurationError
        A matrix of the wrong shape (``A`` not square, ``B`` not n x r, ``C`` not p x n,
        ``D`` not p x r, ``R_c`` not n x n, ``Q_c`` not (n + r) x (n + r)), not finite, or
        ``R_c`` / ``Q_c`` not symmetric positive semidefinite; a non-zero ``D``.

    Examples
    --------
    An integrator ``dx = u dt + dv`` with noise intensity 0.5 (x^2 per second) and cost
    rate ``x^2``, left uncontrolled (its input is connected to nothing: u = 0): from x = 0
    its variance grows as ``0.5 t``, so the expected cost over 2 s is
    ``∫_0^2 0.5 t dt = 1``.

    >>> import numpy as np
    >>> from netcosim import lq
    >>> plant = lq.ContinuousSystem(A=0.0, B=1.0, C=1.0, R_c=0.5, Q_c=np.diag([1.0, 0.0]))
    >>> plant
    ContinuousSystem(n=1, inputs=1, outputs=1)
    >>> loop = lq.Interconnection().add("plant", plant)
    >>> round(lq.Propagator(loop).pass_time(2.0).cost, 9)
    1.0

    A direct term is refused (the held outputs of the discrete systems are what a plant sees):

    >>> lq.ContinuousSystem(0.0, 1.0, 1.0, D=1.0)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    netcosim.errors.ConfigurationError: ContinuousSystem: D must be zero (the system must be strictly proper, ...
    """

    def __init__(self, A: Any, B: Any, C: Any, D: Any = None, R_c: Any = None, Q_c: Any = None):
        name = type(self).__name__
        self.A = square(A, f"{name}: A")
        n = self.A.shape[0]
        self.B = matrix(B, f"{name}: B", (n, None))
        self.C = matrix(C, f"{name}: C", (None, n))
        if D is not None:
            d = matrix(D, f"{name}: D", (self.C.shape[0], self.B.shape[1]))
            if np.any(d != 0.0):
                raise ConfigurationError(f"{name}: D must be zero (the system must be strictly proper, "
                                         f"as in JitterTime), got {show(D)}")
        self.R_c = covariance(R_c, f"{name}: R_c", n)
        self.Q_c = covariance(Q_c, f"{name}: Q_c", n + self.B.shape[1])

    @classmethod
    def from_ss(cls, sys: Any, R_c: Any = None, Q_c: Any = None) -> "ContinuousSystem":
        """From *sys*, any object with ``A``, ``B``, ``C``, ``D`` attributes (a ``control.StateSpace``
        of python-control, if installed; it is not imported here); ``R_c`` (state noise
        intensity) and ``Q_c`` (cost weight on [x; u]) as for the class."""
        try:
            return cls(sys.A, sys.B, sys.C, sys.D, R_c=R_c, Q_c=Q_c)
        except AttributeError:
            raise ConfigurationTypeError(f"{cls.__name__}.from_ss: sys must have A, B, C, D, "
                                         f"got {show(sys)}") from None

    @property
    def states(self) -> int:
        """Its number of entries in the total state (n)."""
        return self.A.shape[0]

    @property
    def inputs(self) -> int:
        """Its number of inputs (r)."""
        return self.B.shape[1]

    @property
    def outputs(self) -> int:
        """Its number of outputs (p)."""
        return self.C.shape[0]

    def __repr__(self) -> str:
        return f"ContinuousSystem(n={self.states}, inputs={self.inputs}, outputs={self.outputs})"


class DiscreteSystem:
    """A discrete-time LTI system executed at events; its state and output are held.

    ``Phi`` (n x n), ``Gamma`` (n x r), ``C`` (p x n), ``D`` (p x r); n may be 0 (a static
    gain, see :meth:`gain`).  ``R_d``: covariance of the noise added to [x; y] at each
    execution ((n + p) x (n + p), symmetric PSD), None for none.  ``Q_c``: continuous-time
    cost weight on the held [x; y] ((n + p) x (n + p), per second), None for no cost.

    Raises
    ------
    ConfigurationTypeError
        A matrix that is not numeric (a string, None, an object).
    ConfigurationError
        A matrix of the wrong shape (``Phi`` not square, ``Gamma`` not n x r, ``C`` not
        p x n), not finite, or ``R_d`` / ``Q_c`` not symmetric positive semidefinite.

    Examples
    --------
    A first-order controller ``x+ = 0.5 x + 2 u``, ``y+ = 3 x + 4 u``, fed by a source held
    at 1: from x = 1, one execution gives x = 0.5 + 2 = 2.5 and y = 3 + 4 = 7.

    >>> from netcosim import lq
    >>> ctrl = lq.DiscreteSystem(Phi=0.5, Gamma=2.0, C=3.0, D=4.0)
    >>> ctrl
    DiscreteSystem(n=1, inputs=1, outputs=1)
    >>> loop = lq.Interconnection().add("src", lq.DiscreteSystem.gain(1.0)).add("c", ctrl, inputs="src")
    >>> p = lq.Propagator(loop).impulse([1.0], system="src").impulse([1.0, 0.0], system="c")
    >>> mean, _ = p.update("c").state("c")
    >>> mean.tolist()
    [2.5, 7.0]
    """

    def __init__(self, Phi: Any, Gamma: Any, C: Any, D: Any, R_d: Any = None, Q_c: Any = None):
        name = type(self).__name__
        self.Phi = square(Phi, f"{name}: Phi")
        n = self.Phi.shape[0]
        self.D = matrix(D, f"{name}: D")
        p, r = self.D.shape
        self.Gamma = matrix(Gamma, f"{name}: Gamma", (n, r))
        self.C = matrix(C, f"{name}: C", (p, n))
        self.R_d = covariance(R_d, f"{name}: R_d", n + p)
        self.Q_c = covariance(Q_c, f"{name}: Q_c", n + p)

    @classmethod
    def gain(cls, D: Any, R_d: Any = None, Q_c: Any = None) -> "DiscreteSystem":
        """A static gain ``y = D u`` (no state): a sampler (``D = I``), a state feedback
        (``D = -L``), an actuator's hold.  ``R_d`` (p x p): noise on y (measurement noise);
        ``Q_c`` (p x p, per second): cost weight on the held y."""
        d = matrix(D, f"{cls.__name__}.gain: D")
        p, r = d.shape
        return cls(np.zeros((0, 0)), np.zeros((0, r)), np.zeros((p, 0)), d, R_d=R_d, Q_c=Q_c)

    @classmethod
    def from_ss(cls, sys: Any, R_d: Any = None, Q_c: Any = None) -> "DiscreteSystem":
        """From *sys*, any object with ``A``, ``B``, ``C``, ``D`` attributes (e.g. a discrete-time
        ``control.StateSpace``; its sampling time is not read -- the executions set it), as
        ``Phi``, ``Gamma``, ``C``, ``D``; ``R_d`` (noise on [x; y] per execution) and ``Q_c``
        (cost weight on the held [x; y]) as for the class."""
        try:
            return cls(sys.A, sys.B, sys.C, sys.D, R_d=R_d, Q_c=Q_c)
        except AttributeError:
            raise ConfigurationTypeError(f"{cls.__name__}.from_ss: sys must have A, B, C, D, "
                                         f"got {show(sys)}") from None

    @property
    def states(self) -> int:
        """Its number of entries in the total state: n + p (state and held output)."""
        return self.Phi.shape[0] + self.D.shape[0]

    @property
    def inputs(self) -> int:
        """Its number of inputs (r)."""
        return self.D.shape[1]

    @property
    def outputs(self) -> int:
        """Its number of (held) outputs (p)."""
        return self.D.shape[0]

    def __repr__(self) -> str:
        return f"DiscreteSystem(n={self.Phi.shape[0]}, inputs={self.inputs}, outputs={self.outputs})"


@dataclass(frozen=True)
class TotalDynamics:
    """The model on its total state z (JitterTime's ``calcDynamics``).

    ``A``, ``R_c``, ``Q_c``: ``dz = A z dt + dv``, ``E[dv dv^T] = R_c dt``, cost rate
    ``z^T Q_c z``.  ``updates[key] = (E, W)``: executing discrete system *key* maps
    ``z -> E z + e`` with ``E[e e^T] = W``.  ``slices[key]``: where a system's entries sit in z.
    ``output_maps[key]``: the matrix that maps z to system *key*'s output (what its
    successors read as input).

    Examples
    --------
    An integrator plant under a sampled gain ``u = -10 x``: z = [x; sampler's y; ctrl's u].
    Between executions only x moves (``dx = u dt``); executing ``"ctrl"`` sets
    ``u = -10 y`` and keeps the rest.

    >>> from netcosim import lq
    >>> loop = (lq.Interconnection()
    ...         .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0), inputs="ctrl")
    ...         .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
    ...         .add("ctrl", lq.DiscreteSystem.gain(-10.0), inputs="sampler"))
    >>> dyn = loop.dynamics()
    >>> dyn.size, dyn.slices["ctrl"]
    (3, slice(2, 3, None))
    >>> dyn.A.tolist()
    [[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
    >>> E, W = dyn.updates["ctrl"]
    >>> E.tolist()
    [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -10.0, 0.0]]
    """

    A: np.ndarray
    R_c: np.ndarray
    Q_c: np.ndarray
    updates: dict[Hashable, tuple[np.ndarray, np.ndarray]]
    slices: dict[Hashable, slice]
    output_maps: dict[Hashable, np.ndarray] = field(repr=False)

    @property
    def size(self) -> int:
        """The length of the total state z."""
        return self.A.shape[0]


class Interconnection:
    """Systems connected output to input; add them with :meth:`add`, in any order.

    The total state z stacks the systems in the order added (a discrete system contributes
    its state and its held output); :meth:`dynamics` builds the model on z once.

    Examples
    --------
    A sampled loop: an integrator plant with white-noise input, a sampler and a static
    controller ``u = -x / h`` (deadbeat for h = 0.1 s); a system may be added before the
    one it reads.

    >>> import numpy as np
    >>> from netcosim import lq
    >>> h = 0.1
    >>> loop = (lq.Interconnection()
    ...         .add("plant", lq.ContinuousSystem(0.0, 1.0, 1.0, R_c=1.0, Q_c=np.diag([1.0, 0.0])),
    ...              inputs="ctrl")
    ...         .add("sampler", lq.DiscreteSystem.gain(1.0), inputs="plant")
    ...         .add("ctrl", lq.DiscreteSystem.gain(-1 / h), inputs="sampler"))
    >>> list(loop.systems), loop.dynamics().size
    (['plant', 'sampler', 'ctrl'], 3)
    >>> loop.slice_of("sampler")
    slice(1, 2, None)
    """

    def __init__(self) -> None:
        self._systems: dict[Hashable, ContinuousSystem | DiscreteSystem] = {}
        self._inputs: dict[Hashable, tuple[Hashable, ...]] = {}
        self._dynamics: TotalDynamics | None = None

    def add(self, key: Hashable, system: ContinuousSystem | DiscreteSystem,
            inputs: Iterable[Hashable] = ()) -> "Interconnection":
        """Add *system* under *key*; its input is the stacked outputs of the systems *inputs*
        (empty: an unconnected input, held at zero).  Returns self, for chaining."""
        if not isinstance(system, (ContinuousSystem, DiscreteSystem)):
            raise ConfigurationTypeError(f"Interconnection.add: system {key!r} must be a ContinuousSystem "
                                         f"or a DiscreteSystem, got {show(system)}")
        if key in self._systems:
            raise ConfigurationError(f"Interconnection.add: system {key!r} is already defined")
        if isinstance(inputs, (str, bytes)) or not isinstance(inputs, Iterable):
            inputs = (inputs,)
        ins = tuple(inputs)
        if key in ins:
            raise ConfigurationError(f"Interconnection.add: system {key!r} cannot be its own input")
        self._systems[key] = system
        self._inputs[key] = ins
        self._dynamics = None
        return self

    @property
    def systems(self) -> dict[Hashable, ContinuousSystem | DiscreteSystem]:
        """The systems by key, in the order added (the order of the total state)."""
        return dict(self._systems)

    def dynamics(self) -> TotalDynamics:
        """The total dynamics (built once, after the last :meth:`add`)."""
        if self._dynamics is None:
            self._dynamics = self._build()
        return self._dynamics

    def _build(self) -> TotalDynamics:
        if not self._systems:
            raise ConfigurationError("Interconnection: no system was added")
        slices: dict[Hashable, slice] = {}
        k = 0
        for key, s in self._systems.items():
            slices[key] = slice(k, k + s.states)
            k += s.states
        N = k
        out: dict[Hashable, np.ndarray] = {}     # z -> output of a system
        for key, s in self._systems.items():
            O = np.zeros((s.outputs, N))
            if isinstance(s, ContinuousSystem):
                O[:, slices[key]] = s.C
            else:
                O[:, slices[key].stop - s.outputs:slices[key].stop] = np.eye(s.outputs)
            out[key] = O
        inp: dict[Hashable, np.ndarray] = {}     # z -> input of a system
        for key, s in self._systems.items():
            for src in self._inputs[key]:
                if src not in self._systems:
                    raise ConfigurationError(f"Interconnection: system {key!r} takes its input from {src!r}, "
                                             f"which is not defined (systems: {list(self._systems)})")
            parts = [out[src] for src in self._inputs[key]]
            width = sum(p.shape[0] for p in parts)
            if not parts:
                inp[key] = np.zeros((s.inputs, N))
            elif width != s.inputs:
                raise ConfigurationError(f"Interconnection: system {key!r} has {s.inputs} input(s) but its "
                                         f"inputs {list(self._inputs[key])} give {width} output(s)")
            else:
                inp[key] = np.vstack(parts)
        A = np.zeros((N, N))
        R_c = np.zeros((N, N))
        Q_c = np.zeros((N, N))
        updates: dict[Hashable, tuple[np.ndarray, np.ndarray]] = {}
        for key, s in self._systems.items():
            sl = slices[key]
            sel = np.zeros((s.states, N))
            sel[:, sl] = np.eye(s.states)
            if isinstance(s, ContinuousSystem):
                A[sl, :] = s.B @ inp[key]
                A[sl, sl] += s.A
                R_c[sl, sl] = s.R_c
                M = np.vstack([sel, inp[key]])       # z -> [x; u]
                Q_c += M.T @ s.Q_c @ M
            else:
                n = s.Phi.shape[0]
                E = np.eye(N)
                E[sl, :] = np.vstack([s.Gamma @ inp[key], s.D @ inp[key]])
                E[sl.start:sl.start + n, sl] += np.hstack([s.Phi, np.zeros((n, s.outputs))])
                E[sl.start + n:sl.stop, sl] += np.hstack([s.C, np.zeros((s.outputs, s.outputs))])
                W = np.zeros((N, N))
                W[sl, sl] = s.R_d
                updates[key] = (E, W)
                Q_c += sel.T @ s.Q_c @ sel
        return TotalDynamics(A=A, R_c=R_c, Q_c=0.5 * (Q_c + Q_c.T), updates=updates, slices=slices,
                             output_maps=out)

    def slice_of(self, key: Hashable) -> slice:
        """Where system *key*'s entries sit in the total state (a discrete system: [x; y])."""
        dyn = self.dynamics()
        if key not in dyn.slices:
            raise ConfigurationError(f"no system {key!r} (systems: {list(dyn.slices)})")
        return dyn.slices[key]

    def update_of(self, key: Hashable) -> tuple[np.ndarray, np.ndarray]:
        """``(E, W)`` of executing discrete system *key* (error naming it otherwise)."""
        dyn = self.dynamics()
        if key not in dyn.updates:
            kind = "a continuous system" if key in dyn.slices else "not defined"
            raise ConfigurationError(f"system {key!r} cannot be executed: it is {kind} "
                                     f"(discrete systems: {list(dyn.updates)})")
        return dyn.updates[key]

    def reset_map(self, key: Hashable, A: Any, B: Any = None, inputs: Iterable[Hashable] = (),
                  R: Any = None) -> tuple[np.ndarray, np.ndarray]:
        """``(E, W)`` of a jump of system *key*'s entries: ``x+ = A x + B u + e``, ``E[e e^T] = R``,
        u the stacked outputs of *inputs*; every other entry of z is kept (JitterTime's
        reset dynamics, ``jtAddResetDynamics``; e.g. a mode switch of a controller)."""
        dyn = self.dynamics()
        sl = self.slice_of(key)
        n = sl.stop - sl.start
        A = square(A, f"reset of {key!r}: A", n)
        E = np.eye(dyn.size)
        E[sl, :] = 0.0
        E[sl, sl] = A
        ins = tuple(inputs)
        if ins:
            for src in ins:
                if src not in dyn.output_maps:
                    raise ConfigurationError(f"reset of {key!r}: input {src!r} is not defined")
            U = np.vstack([dyn.output_maps[src] for src in ins])
            Bm = matrix(B, f"reset of {key!r}: B", (n, U.shape[0]))
            E[sl, :] += Bm @ U
        elif B is not None:
            raise ConfigurationError(f"reset of {key!r}: B given without inputs")
        W = np.zeros_like(E)
        W[sl, sl] = covariance(R, f"reset of {key!r}: R", n)
        return E, W
