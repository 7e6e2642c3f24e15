"""Low-overhead numeric evaluation of CasADi Functions.

Calling a ``casadi.Function`` from Python converts every argument to ``DM`` and back,
which costs tens of microseconds — more than evaluating the plant equations.  CasADi's
buffer interface (``Function.buffer()``) evaluates into preallocated memory instead;
:class:`BufferedFunction` wraps it with a numpy-in/numpy-out call.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

__all__ = ["BufferedFunction"]


class BufferedFunction:
    """``BufferedFunction(f)(*args) -> [numpy arrays]``: evaluate *f* numerically.

    Inputs must be dense (any array-like of the right size, copied in); outputs are
    returned as fresh arrays: shape ``(k,)`` for column vectors, ``(rows, cols)``
    otherwise, with sparse outputs scattered into dense zeros.
    """

    def __init__(self, fun: ca.Function):
        self.fun = fun
        self._in = []
        for i in range(fun.n_in()):
            sp = fun.sparsity_in(i)
            if not sp.is_dense():
                raise ValueError(f"{fun.name()}: input {i} must be dense")
            self._in.append(np.zeros(sp.nnz()))
        self._out, self._shape, self._scatter = [], [], []
        for i in range(fun.n_out()):
            sp = fun.sparsity_out(i)
            self._out.append(np.zeros(sp.nnz()))
            shape = (sp.size1(),) if sp.size2() == 1 else (sp.size1(), sp.size2())
            self._shape.append(shape)
            if sp.is_dense():
                self._scatter.append(None)
            else:
                r, c = sp.get_triplet()
                self._scatter.append((np.asarray(r, dtype=int), np.asarray(c, dtype=int)))
        self._buf, self._eval = fun.buffer()
        for i, a in enumerate(self._in):
            self._buf.set_arg(i, memoryview(a))
        for i, a in enumerate(self._out):
            self._buf.set_res(i, memoryview(a))

    def __call__(self, *args):
        if len(args) != len(self._in):
            raise TypeError(f"{self.fun.name()} takes {len(self._in)} arguments, got {len(args)}")
        for dst, a in zip(self._in, args):
            dst[:] = np.ravel(a, order="F") if np.ndim(a) > 1 else a
        self._eval()
        res = []
        for nz, shape, sc in zip(self._out, self._shape, self._scatter):
            if sc is None:
                res.append(nz.reshape(shape, order="F").copy() if len(shape) == 2 else nz.copy())
            else:
                d = np.zeros(shape if len(shape) == 2 else (shape[0], 1))
                d[sc[0], sc[1]] = nz
                res.append(d if len(shape) == 2 else d[:, 0])
        return res
