"""Energy (7.8) and energy rate (7.13) of the acrobot."""
from __future__ import annotations

import numpy as np

from ...params import FrictionParams, PlantParams
from ...systems.friction import friction_torques
from ...systems.plant import kinetic_energy, potential_energy


def energy(x, p: PlantParams):
    """Total energy (7.8) of state rows ``x = (q1, q2, q1d, q2d)``; returns
    (kinetic, potential, total) arrays."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    ke = np.array([kinetic_energy(r[:2], r[2:], p) for r in x])
    pe = np.array([potential_energy(r[:2], p) for r in x])
    return ke, pe, ke + pe


def energy_rate(x, tau2, p_friction: FrictionParams):
    """(7.13): E' = qd . (tau - f) with tau = (0, tau2)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    tau2 = np.broadcast_to(np.asarray(tau2, dtype=float), (x.shape[0],))
    f = np.array([friction_torques(r[2:], p_friction) for r in x])
    return x[:, 2] * (0.0 - f[:, 0]) + x[:, 3] * (tau2 - f[:, 1])


def energy_rate_from_forces(x, tau2, generalized_friction_force):
    """(7.13) with the friction force as logged (``-f``)."""
    x = np.atleast_2d(np.asarray(x, dtype=float))
    gf = np.atleast_2d(generalized_friction_force)
    return x[:, 2] * gf[:, 0] + x[:, 3] * (np.ravel(tau2) + gf[:, 1])
