"""The closed loops of a plant and its two-degree-of-freedom controller in
state space, balanced, and their step responses (python-control; the
time-domain half of :func:`~bplir_drake.analysis.control.qft.verify`)."""
from __future__ import annotations

import control
import numpy as np


def closed_loops(plant_tf, K, F):
    """Closed-loop maps built in state space (transfer-function arithmetic
    of high order is numerically fragile), each balanced (:func:`balanced`)."""
    G, Ks, Fs = control.ss(plant_tf), control.ss(K), control.ss(F)
    L = G * Ks
    S = control.feedback(control.ss([], [], [], [[1.0]]), L)
    T = control.feedback(L, control.ss([], [], [], [[1.0]]))
    return tuple(balanced(m) for m in (L, S, T, T * Fs, Ks * S * Fs, control.feedback(G, Ks)))


def balanced(sys):
    """``sys`` (state space) under the diagonal similarity, of powers of two
    (exact), that balances its ``A`` (``scipy.linalg.matrix_balance``): the
    same transfer function.  The canonical realisations of the closed loops
    of a plant with its delay's Pade approximant are so badly conditioned
    that step responses simulated on them stray from the solution;
    balanced, they follow it."""
    import scipy.linalg

    if not sys.nstates:
        return sys
    A = np.asarray(sys.A, dtype=float)
    _, (scale, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    return control.ss(A / scale[:, None] * scale[None, :], np.asarray(sys.B) / scale[:, None],
                      np.asarray(sys.C) * scale[None, :], sys.D)


def step_responses(systems, t) -> list:
    """The unit-step responses of the SISO state-space ``systems`` (balanced)
    on the grid ``t``: one simulation of their block-diagonal union
    (``control.append``, each input driving its own system), one time loop
    for all."""
    joined = control.append(*systems)
    return list(control.forced_response(joined, t, np.ones((len(systems), len(t)))).outputs)
