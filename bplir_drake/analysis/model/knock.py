"""The size of a knock in a robot's own terms, and the knocks of a run.

:func:`knock_torque` is the torque of a knock of a given severity on one
joint (:mod:`bplir_drake.params.knocks`: the pulse that alone would swing
the free link of the robot hanging at rest from gripper 1, motor off and
without friction, ``severity`` x 30 deg from where it hangs at its peak), found by
simulating the closed-form model of the robot's description.
:class:`KnockClock` draws a run's knocks from its seed, in the run's time,
and hands each phase of the run the knocks that fall in it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ...params import PlantParams
from ...params.follow import robot_scales
from ...params.knocks import (DURATION_SHARE, GAP_SPREAD, SEVERITY_SWING_DEG,
                              SWING_KNOCK_WINDOW, Knocks)
from ...systems.plant import forward_dynamics, gravity_vector

#: the joints of a knock by name: index 0 the holding gripper's, 1 the elbow
JOINT_INDEX = {"hold": 0, "elbow": 1}


def knock_duration(plant: PlantParams) -> float:
    """A knock's duration (s) on ``plant``: ``DURATION_SHARE`` of its sqrt(L/g)."""
    return DURATION_SHARE * robot_scales(plant)[0]


#: how long the free link is watched after a knock, in the robot's time
#: unit: at least one and a half of a two-link pendulum's slowest period
#: (which is at most 2 pi sqrt(L/g))
WATCH = 3.0 * math.pi


def hanging_rest(plant: PlantParams) -> np.ndarray:
    """The joint angles (rad) at which ``plant`` hangs at rest from gripper
    1 (0, 0 unless a centre of mass lies off its link's axis)."""
    from scipy.optimize import fsolve

    q, _, ok, msg = fsolve(lambda q: gravity_vector(q, plant), np.zeros(2), full_output=True,
                           xtol=1e-12)
    if ok != 1:
        raise ValueError(f"no pose at which the robot hangs at rest: {msg}")
    return np.asarray(q, dtype=float)


def free_link_peak(plant: PlantParams, torque: float, joint: int) -> float:
    """The free link's largest angle (rad) from where it hangs after a
    pulse of ``torque`` N m on ``joint`` (0, 1) for :func:`knock_duration`
    on the robot hanging at rest, motor off, without friction, within
    :data:`WATCH` of its time unit (longer than the slowest period of a
    two-link pendulum, ``2 pi sqrt(L/g)``)."""
    from scipy.integrate import solve_ivp

    d = knock_duration(plant)
    t_unit = robot_scales(plant)[0]

    def rhs(t, x):
        tau = np.zeros(2)
        if t < d:
            tau[joint] = torque
        qdd = forward_dynamics(x[:2], x[2:], tau[1], -np.array([tau[0], 0.0]), plant)
        return np.r_[x[2:], qdd]

    q0 = hanging_rest(plant)
    x0 = np.r_[q0, 0.0, 0.0]
    pulse = solve_ivp(rhs, (0.0, d), x0, rtol=1e-9, atol=1e-12, max_step=d / 20)
    after = solve_ivp(rhs, (d, d + WATCH * t_unit), pulse.y[:, -1], rtol=1e-8,
                      atol=1e-10, dense_output=True)
    later = after.sol(np.linspace(d, d + WATCH * t_unit, 2000))
    theta2 = np.r_[pulse.y[0] + pulse.y[1], later[0] + later[1]] - (q0[0] + q0[1])
    return float(np.max(np.abs(theta2)))


@lru_cache(maxsize=256)
def knock_torque(plant: PlantParams, severity: float, joint: int) -> float:
    """The torque (N m) of a knock of ``severity`` on ``joint`` (0: the
    holding gripper's, 1: the elbow) of ``plant`` (module docs); 0 for
    severity 0.  Raises ``ValueError`` when no pulse reaches the swing (a
    severity beyond what the free link can swing to)."""
    from scipy.optimize import brentq

    if severity <= 0:
        return 0.0
    goal = math.radians(severity * SEVERITY_SWING_DEG)
    torque_unit = robot_scales(plant)[1]
    hi = 0.05 * torque_unit   # doubled until it swings the free link that far
    while free_link_peak(plant, hi, joint) < goal:
        hi *= 2.0
        if hi > 1e3 * torque_unit:
            raise ValueError(f"no knock on joint {joint + 1} swings the free link "
                             f"{math.degrees(goal):.0f} deg")
    return float(brentq(lambda T: free_link_peak(plant, T, joint) - goal, 0.0, hi,
                        xtol=1e-6 * torque_unit, rtol=1e-6))


@dataclass(frozen=True)
class Knock:
    """One knock: its time in the run (s), the torques on joint 1 and 2
    (N m, of the robot held by gripper 1) and how long it lasts (s)."""

    t: float
    torque: tuple[float, float]
    duration: float


class KnockClock:
    """A run's knocks, drawn from ``numpy.random.default_rng([seed, 7, 0])``
    as the run goes: gaps of ``60 / rate`` s on average (uniform within
    ``GAP_SPREAD`` of it), the first one gap after the start; each on the
    joints ``knocks.joints`` names, its direction on each joint drawn.
    :meth:`take` hands out the knocks of a stretch of the run's time once."""

    def __init__(self, knocks: Knocks, plant: PlantParams, seed: int):
        self.knocks = knocks
        self.rng = np.random.default_rng([int(seed), 7, 0])
        self.duration = knock_duration(plant)
        self.size = (knock_torque(plant, knocks.severity, 0),
                     knock_torque(plant, knocks.severity, 1))
        self.drawn: list[Knock] = []
        self.next = 0   # the first knock not handed out yet
        self._t = 0.0

    def _draw(self) -> Knock:
        gap = 60.0 / self.knocks.rate
        self._t += gap * self.rng.uniform(1.0 - GAP_SPREAD, 1.0 + GAP_SPREAD)
        joints = self.knocks.joints
        if joints == "either":
            joints = ("hold", "elbow")[int(self.rng.integers(2))]
        on = (0, 1) if joints == "both" else (JOINT_INDEX[joints],)
        signs = self.rng.choice((-1.0, 1.0), 2)
        torque = [0.0, 0.0]
        for j in on:
            torque[j] = float(signs[j] * self.size[j])
        k = Knock(self._t, (torque[0], torque[1]), self.duration)
        self.drawn.append(k)
        return k

    def upcoming(self, t0: float, t1: float) -> list[Knock]:
        """The knocks not handed out that start before ``t1``, from ``t0``
        on (earlier ones were absorbed where nothing could take them)."""
        if not self.knocks.active:
            return []
        while not self.drawn or self.drawn[-1].t < t1:
            self._draw()
        return [k for k in self.drawn[self.next:] if t0 - 1e-12 <= k.t < t1]

    def take(self, t1: float) -> list[Knock]:
        """Hand out every knock that starts before ``t1``."""
        if not self.knocks.active:
            return []
        self.upcoming(0.0, t1)
        first = self.next
        while self.next < len(self.drawn) and self.drawn[self.next].t < t1:
            self.next += 1
        return self.drawn[first:self.next]


def pulses_from(knocks: list[Knock], t0: float):
    """``[(start s, (tau1, tau2) N m, duration s)]`` of ``knocks`` in the
    time of a simulation that starts at the run's ``t0`` (on whichever
    gripper holds: a knock's direction is drawn)."""
    return [(k.t - t0, k.torque, k.duration) for k in knocks]


def swing_knock(plant: PlantParams, severity: float, seed: int):
    """The one knock of a benchmark's knocked swing, as pulses
    (:func:`pulses_from`): at a time drawn uniformly within
    ``SWING_KNOCK_WINDOW`` sqrt(L/g) of the start, on one joint drawn, its
    direction drawn, from ``numpy.random.default_rng([seed, 7, 1])``."""
    rng = np.random.default_rng([int(seed), 7, 1])
    t = float(rng.uniform(0.0, SWING_KNOCK_WINDOW * robot_scales(plant)[0]))
    joint = int(rng.integers(2))
    torque = [0.0, 0.0]
    torque[joint] = float(rng.choice((-1.0, 1.0)) * knock_torque(plant, severity, joint))
    return [(t, (torque[0], torque[1]), knock_duration(plant))]
