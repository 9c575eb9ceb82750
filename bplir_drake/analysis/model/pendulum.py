"""Open-loop speed of the BPLIR as a pendulum, (6.11)-(6.15).

Erratum: (6.14) claims the CoM radius is smallest when the robot is folded
(q2 = pi) but its formula ``(m1 lc1 + (l1 + lc2) m2)/(m1 + m2)`` is the radius
with the links *straight* (q2 = 0), which is the largest radius.  That
formula gives the published T = 1.57 s; the folded configuration gives about
1.03 s.  As a compound pendulum (inertia included) the straight robot swings
with about 2.4 s.
"""
from __future__ import annotations

import math

import numpy as np
from dataclasses import dataclass

from ...params import PlantParams
from ...systems.plant import link_centres_of_mass, mass_matrix


def simple_pendulum_period(r_com: float, g: float) -> float:
    """(6.11): T = 2 pi sqrt(r/g)."""
    return 2.0 * math.pi * math.sqrt(r_com / g)


def com_radius(p: PlantParams, q2: float) -> float:
    """Distance pivot-CoM with the elbow at ``q2`` (6.12)-(6.13), q1 = 0."""
    com = link_centres_of_mass([0.0, q2], p)
    return float(np.hypot(*(p.m1 * com[0] + p.m2 * com[1]))) / (p.m1 + p.m2)


def compound_pendulum_period(p: PlantParams, q2: float) -> float:
    """Small-oscillation period with the elbow locked at ``q2``."""

    m11 = mass_matrix([0.0, q2], p)[0, 0]
    return 2.0 * math.pi * math.sqrt(m11 / ((p.m1 + p.m2) * p.g * com_radius(p, q2)))


@dataclass(frozen=True)
class PendulumPeriods:
    """Pendulum periods (s) of the robot: (6.14) as printed and its radius (m), and the simple and
    compound periods folded (q2 = pi) and straight (q2 = 0)."""
    T_min_printed: float      # (6.14) as printed -> 1.57 s (really q2 = 0, straight)
    r_printed: float
    T_folded: float           # q2 = pi, the smallest CoM radius
    T_straight_compound: float
    T_folded_compound: float


def pendulum_periods(p: PlantParams) -> PendulumPeriods:
    """The :class:`PendulumPeriods` of plant ``p``."""
    r_printed = (p.m1 * p.lc1 + (p.l1 + p.lc2) * p.m2) / (p.m1 + p.m2)  # (6.14)
    return PendulumPeriods(
        T_min_printed=simple_pendulum_period(r_printed, p.g),
        r_printed=r_printed,
        T_folded=simple_pendulum_period(com_radius(p, math.pi), p.g),
        T_straight_compound=compound_pendulum_period(p, 0.0),
        T_folded_compound=compound_pendulum_period(p, math.pi),
    )
