"""Zero dynamics of the CPFL loop (Figs 6.2-6.3).

With the actuated elbow held at ``q2 = q2*`` (q2' = q2'' = 0) the passive
link obeys the first row of (4.5): ``M11(q2*) q1'' + g1(q1, q2*) = -f1(q1')``
-- a pendulum with the elbow locked.  Without friction the orbits are closed
curves (limit cycles around the hanging equilibrium, Fig. 6.2); with the
friction (4.11) they spiral into a stable focus at the origin (Fig. 6.3).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from ...params import FrictionParams, PlantParams
from ...systems.friction import joint_friction
from ...systems.plant import gravity_vector, mass_matrix, potential_energy


@dataclass
class PhasePortrait:
    """Orbits (t, q1, q1') of link 1 with the elbow held at ``q2_star`` (rad), with or without
    friction."""
    q2_star: float
    friction: bool
    trajectories: list  # each (t, q1, q1d)

    def final_radius(self) -> np.ndarray:
        """Distance of each orbit's end from the origin in the (q1, q1') plane."""
        return np.array([np.hypot(q1[-1], qd[-1]) for _, q1, qd in self.trajectories])

    def energy_like(self, p: PlantParams) -> list[np.ndarray]:
        """``0.5 M11 q1'^2 + V(q1)`` along each orbit (conserved without friction)."""
        M11 = mass_matrix([0.0, self.q2_star], p)[0, 0]
        out = []
        for _, q1, qd in self.trajectories:
            V = np.array([_potential(q, self.q2_star, p) for q in q1])
            out.append(0.5 * M11 * qd ** 2 + V)
        return out


def _potential(q1, q2, p):
    return potential_energy([q1, q2], p)


def zero_dynamics_portrait(p: PlantParams, friction: FrictionParams | None, *, q2_star=0.0,
                           initial=None, duration: float = 12.0) -> PhasePortrait:
    """Orbits of the zero dynamics from a set of initial (q1, q1')."""
    if initial is None:
        initial = [(a, 0.0) for a in (0.3, 0.8, 1.3, 1.8, 2.4)] + [(0.0, w) for w in (2.0, 4.0)]
    M11 = mass_matrix([0.0, q2_star], p)[0, 0]
    # with the elbow held, link 1's gravity torque is one sinusoid of q1 (every
    # term of g1 is a sin(q1 + const)): a sin q1 + b cos q1, read off the model
    a, b = (float(gravity_vector([q, q2_star], p)[0]) for q in (0.5 * math.pi, 0.0))
    law = (friction.fv1, friction.fc1, friction.b, friction.drag_coefficients()[0]) \
        if friction is not None and friction.enabled else None

    def rhs(t, x):
        f1 = joint_friction(x[1], *law) if law else 0.0
        return [x[1], (-(a * math.sin(x[0]) + b * math.cos(x[0])) - f1) / M11]

    trajs = []
    # sampled every 10 ms for the portrait; the eighth-order steps in between
    # are as long as the tolerance allows (a max_step of 10 ms instead made
    # the solver take about 6x the evaluations)
    t_eval = np.linspace(0.0, duration, int(round(duration / 0.01)) + 1)
    for q10, w0 in initial:
        sol = solve_ivp(rhs, (0.0, duration), [q10, w0], method="DOP853", t_eval=t_eval,
                        rtol=1e-10, atol=1e-12)
        trajs.append((sol.t, sol.y[0], sol.y[1]))
    return PhasePortrait(q2_star, friction is not None, trajs)
