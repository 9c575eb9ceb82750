"""The wrist-wheel drive: riding the line between obstacles (closed form).

The dissertation's robot rides on actuated wrist wheels (chapter 1) but
gives no drive data; :class:`~bplir_drake.params.DriveParams` holds ours.
A ride is a trapezoidal speed profile (accelerate at ``max_accel``, cruise,
brake) whose cruise speed is the smallest of ``max_speed``, a requested
speed and the speed the power limit allows against rolling resistance and
the climb.  The electrical energy pays rolling resistance, the climb and
the kinetic energy of each start at ``efficiency``; nothing is recovered
downhill or when braking.  No elbow torque is needed while both grippers
hold, so the elbow driver's i^2 t integral falls during a ride.
"""
from __future__ import annotations

import math

from ..params import DriveParams

G = 9.81


def cruise_speed(force: float, p: DriveParams, speed: float | None = None) -> float:
    """The cruise speed (m/s) against a resisting ``force`` (N) within the
    speed and power limits."""
    v = p.max_speed if speed is None else min(speed, p.max_speed)
    if force > 0.0:
        v = min(v, p.power_limit * p.efficiency / force)
    return v


def profile_time(distance: float, v: float, a: float) -> float:
    """Time (s) to cover ``distance`` (m) from rest to rest with cruise speed
    ``v`` and acceleration ``a`` (a triangle when it never reaches ``v``)."""
    d = abs(distance)
    if d * a >= v * v:
        return d / v + v / a
    return 2.0 * math.sqrt(d / a)


def ride(distance: float, rise: float, mass: float, p: DriveParams,
         speed: float | None = None) -> tuple[float, float, float]:
    """``(time s, electrical energy J, peak electrical power W)`` of riding
    ``distance`` m along the line (either way) while rising ``rise`` m, for
    a robot of ``mass`` kg."""
    d = abs(distance)
    if d == 0.0:
        return 0.0, 0.0, 0.0
    sin_a = max(-1.0, min(1.0, rise / d))
    cos_a = math.sqrt(1.0 - sin_a * sin_a)
    force = mass * G * (p.rolling_resistance * cos_a + sin_a)
    v = cruise_speed(force, p, speed)
    t = profile_time(d, v, p.max_accel)
    v_top = min(v, math.sqrt(d * p.max_accel))
    work = max(force, 0.0) * d + 0.5 * mass * v_top ** 2
    peak = (max(force, 0.0) + mass * p.max_accel) * v_top / p.efficiency
    return t, work / p.efficiency, peak


__all__ = ["ride", "cruise_speed", "profile_time"]
