"""An independent reference for the linear-quadratic tests: the map of one period of a
loop, composed step by step from its executions and intervals (no timing model, no
propagator), for the Markov jump linear systems the tests solve as one linear equation."""

from __future__ import annotations

import numpy as np

from netcosim.lq.integrals import interval_matrices


def period_map(model, seq):
    """``(F, W, G, c)`` of the step sequence *seq* (``("x", system)`` executes a discrete
    system, ``("w", seconds)`` waits): the period-start state z maps to ``F z`` plus noise
    of covariance ``W``, and the period costs ``tr(G P) + c`` from a start second moment P."""
    d = model.dynamics()
    N = d.size
    F, W, G, c = np.eye(N), np.zeros((N, N)), np.zeros((N, N)), 0.0
    for kind, v in seq:
        if kind == "x":
            E, V = model.update_of(v)
        else:
            M = interval_matrices(d.A, d.R_c, d.Q_c, v)
            G += F.T @ M.Q @ F
            c += float(np.sum(M.Q * W)) + M.J_noise
            E, V = M.Phi, M.R
        F, W = E @ F, E @ W @ E.T + V
    return F, W, G, c
