"""The controller's nominal model compiled: the acrobot's closed form with
friction (4.11) on plain floats, the delay predictor's RK4 over it and the
apex shot's Newton solve, each one numba function.

These run many times per tick (the predictor 4 x 2 x D rate evaluations,
the shot about fifty per solve), so they are compiled; the constants of a
plant and its friction are folded once into an array by :func:`pack`.
Tested against the plain-Python model
(:func:`~bplir_drake.systems.predictor.nominal_rates`) and the numpy
functions to rounding.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..params import FrictionParams, PlantParams

# the packed constants' indices
(_A, _M11, _K12, _G1, _P1, _D2, _G12, _ON, _FV1, _FC1, _FV2, _FC2, _B, _DR1, _DR2,
 _L1, _L2) = range(17)


def pack(plant: PlantParams, friction: FrictionParams) -> np.ndarray:
    """The nominal model's folded constants: ``a = I2 + m2 rc2^2``, ``M11``'s
    constant part, ``m2 l1 rc2``, link 1's gravity amplitude and phase, the
    elbow's offset angle, ``m2 g rc2``, whether friction is on, its viscous,
    Coulomb and smoothing coefficients and drag per joint, the link lengths."""
    a = plant.I2 + plant.m2 * plant.rc2 ** 2
    (g1, p1), (d1, d2) = plant.gravity_link1(), friction.drag_coefficients()
    return np.array([a, plant.m1 * plant.rc1 ** 2 + plant.I1 + plant.m2 * plant.l1 ** 2 + a,
                     plant.m2 * plant.l1 * plant.rc2, g1, p1, plant.dc2,
                     plant.m2 * plant.g * plant.rc2, float(friction.enabled),
                     friction.fv1, friction.fc1, friction.fv2, friction.fc2, friction.b, d1, d2,
                     plant.l1, plant.l2])


@njit(cache=True)
def joint_friction(c, i, v):
    """Joint ``i``'s friction torque (0 link 1, 1 the elbow) at rate ``v``."""
    if c[_ON] == 0.0:
        return 0.0
    fv, fc, dr = (c[_FV1], c[_FC1], c[_DR1]) if i == 0 else (c[_FV2], c[_FC2], c[_DR2])
    return fv * v + fc * (2.0 / math.pi) * math.atan(v / c[_B]) + dr * v * abs(v)


@njit(cache=True)
def rates(c, q1, q2, v1, v2, tau):
    """(q1', q2', q1'', q2'') at the elbow torque ``tau`` (N m)."""
    c2, s2 = math.cos(q2 + c[_D2]), math.sin(q2 + c[_D2])
    s1, s12 = math.sin(q1 + c[_P1]), math.sin(q1 + q2 + c[_D2])
    a, k12, g12 = c[_A], c[_K12], c[_G12]
    m12 = a + k12 * c2
    m11 = c[_M11] + 2.0 * k12 * c2
    h = k12 * s2
    r0 = h * (2.0 * v1 * v2 + v2 * v2) - (c[_G1] * s1 + g12 * s12) - joint_friction(c, 0, v1)
    r1 = tau - h * v1 * v1 - g12 * s12 - joint_friction(c, 1, v2)
    det = m11 * a - m12 * m12
    return v1, v2, (a * r0 - m12 * r1) / det, (m11 * r1 - m12 * r0) / det


@njit(cache=True)
def predict(c, x, commands, period, substeps):
    """The state after ``len(commands)`` ticks of ``period`` from ``x``, each
    command held over its tick (RK4, ``substeps`` per tick)."""
    x0, x1, x2, x3 = x[0], x[1], x[2], x[3]
    h = period / substeps
    h2, h6 = 0.5 * h, h / 6.0
    for tau in commands:
        for _ in range(substeps):
            a0, a1, a2, a3 = rates(c, x0, x1, x2, x3, tau)
            b0, b1, b2, b3 = rates(c, x0 + h2 * a0, x1 + h2 * a1, x2 + h2 * a2, x3 + h2 * a3, tau)
            d0, d1, d2, d3 = rates(c, x0 + h2 * b0, x1 + h2 * b1, x2 + h2 * b2, x3 + h2 * b3, tau)
            e0, e1, e2, e3 = rates(c, x0 + h * d0, x1 + h * d1, x2 + h * d2, x3 + h * d3, tau)
            x0 += h6 * (a0 + 2.0 * b0 + 2.0 * d0 + e0)
            x1 += h6 * (a1 + 2.0 * b1 + 2.0 * d1 + e1)
            x2 += h6 * (a2 + 2.0 * b2 + 2.0 * d2 + e2)
            x3 += h6 * (a3 + 2.0 * b3 + 2.0 * d3 + e3)
    return np.array([x0, x1, x2, x3])


@njit(cache=True)
def link1_accel(c, q1, q2, v1, v2, a2):
    """Link 1's acceleration (passive joint) with the elbow accelerating at
    ``a2``."""
    c2, s2 = math.cos(q2 + c[_D2]), math.sin(q2 + c[_D2])
    m12, m11 = c[_A] + c[_K12] * c2, c[_M11] + 2.0 * c[_K12] * c2
    bias = -c[_K12] * s2 * (2.0 * v1 * v2 + v2 * v2)
    grav = c[_G1] * math.sin(q1 + c[_P1]) + c[_G12] * math.sin(q1 + q2 + c[_D2])
    return -(m12 * a2 + bias + grav + joint_friction(c, 0, v1)) / m11


@njit(cache=True)
def elbow_torque(c, q1, q2, v1, v2, a2):
    """The elbow torque that gives the elbow acceleration ``a2`` (link 1
    passive)."""
    a1 = link1_accel(c, q1, q2, v1, v2, a2)
    m12 = c[_A] + c[_K12] * math.cos(q2 + c[_D2])
    return (m12 * a1 + c[_A] * a2 + c[_K12] * math.sin(q2 + c[_D2]) * v1 * v1
            + c[_G12] * math.sin(q1 + q2 + c[_D2]) + joint_friction(c, 1, v2))


@njit(cache=True)
def _elbow(q2, v2, k2, k3, k4, t, c):
    """The quartic's angle, rate, acceleration and its inertia terms at ``t``."""
    q2t = q2 + v2 * t + k2 * t * t + k3 * t ** 3 + k4 * t ** 4
    v2t = v2 + 2 * k2 * t + 3 * k3 * t * t + 4 * k4 * t ** 3
    a2t = 2 * k2 + 6 * k3 * t + 12 * k4 * t * t
    c2 = math.cos(q2t + c[_D2])
    return q2t, v2t, a2t, math.sin(q2t + c[_D2]), c[_A] + c[_K12] * c2, c[_M11] + 2.0 * c[_K12] * c2


@njit(cache=True)
def _accel(c, q2t, v2t, a2t, s2, m12, m11, q, w):
    """Link 1's acceleration at (q, w) with the elbow at the quartic's point."""
    bias = -c[_K12] * s2 * (2.0 * w * v2t + v2t * v2t)
    grav = c[_G1] * math.sin(q + c[_P1]) + c[_G12] * math.sin(q + q2t + c[_D2])
    return -(m12 * a2t + bias + grav + joint_friction(c, 0, w)) / m11


@njit(cache=True)
def shoot(c, x, T, q2f, steps, alpha, height):
    """(link 1's rate at ``T``, the gripper's distance to the line then less
    ``height``, the elbow's acceleration now) of the quartic to ``q2f`` at
    rest with zero acceleration at ``T``: RK4 on link 1 in ``steps``."""
    q1, q2, v1, v2 = x[0], x[1], x[2], x[3]
    d, vT = q2f - q2 - v2 * T, v2 * T
    k2 = (6.0 * d + 3.0 * vT) / T ** 2
    k3 = -(8.0 * d + 5.0 * vT) / T ** 3
    k4 = (3.0 * d + 2.0 * vT) / T ** 4
    dt = T / steps
    h2, h6 = dt / 2, dt / 6
    t = 0.0
    e0 = _elbow(q2, v2, k2, k3, k4, t, c)
    for _ in range(steps):
        em = _elbow(q2, v2, k2, k3, k4, t + h2, c)
        e1 = _elbow(q2, v2, k2, k3, k4, t + dt, c)
        d1 = _accel(c, e0[0], e0[1], e0[2], e0[3], e0[4], e0[5], q1, v1)
        w2 = v1 + h2 * d1
        d2 = _accel(c, em[0], em[1], em[2], em[3], em[4], em[5], q1 + h2 * v1, w2)
        w3 = v1 + h2 * d2
        d3 = _accel(c, em[0], em[1], em[2], em[3], em[4], em[5], q1 + h2 * w2, w3)
        w4 = v1 + dt * d3
        d4 = _accel(c, e1[0], e1[1], e1[2], e1[3], e1[4], e1[5], q1 + dt * w3, w4)
        q1 += h6 * (v1 + 2 * w2 + 2 * w3 + w4)
        v1 += h6 * (d1 + 2 * d2 + 2 * d3 + d4)
        t += dt
        e0 = e1
    s = q1 - alpha
    h = -c[_L1] * math.cos(s) - c[_L2] * math.cos(s + q2f)
    return v1, h - height, 2.0 * k2


@njit(cache=True)
def deceleration(c, x):
    """Link 1's deceleration with the elbow held (rad/s^2; negative while
    gravity speeds it up), friction left out."""
    q1, q2, v1, v2 = x[0], x[1], x[2], x[3]
    c2, s2 = math.cos(q2 + c[_D2]), math.sin(q2 + c[_D2])
    bias = -c[_K12] * s2 * (2.0 * v1 * v2 + v2 * v2)
    grav = c[_G1] * math.sin(q1 + c[_P1]) + c[_G12] * math.sin(q1 + q2 + c[_D2])
    return (bias + grav) / (c[_M11] + 2.0 * c[_K12] * c2)


@njit(cache=True)
def solve_shot(c, x, steps, alpha, height, min_rate, min_time, hold_depth):
    """(found, the elbow's acceleration now, ``T``) of the apex shot
    (:meth:`~bplir_drake.systems.landing.ApexShot.solve`): Newton on
    ``(T, q2f)`` from link 1 stopping at its present deceleration; with
    too little time or rate left, ``T`` held at ``min_time`` and ``q2f``
    alone solved for, where the gripper is within ``hold_depth`` of the
    aim."""
    if x[2] > min_rate:
        T, q2f = min(0.5, max(0.03, x[2] / max(deceleration(c, x), 2.0))), x[1]
        done = False
        for _ in range(8):
            r0, r1, acc = shoot(c, x, T, q2f, steps, alpha, height)
            if abs(r0) < 1e-3 and abs(r1) < 1e-4:
                done = True
                break
            a0, a1, _ = shoot(c, x, T + 1e-4, q2f, steps, alpha, height)
            b0, b1, _ = shoot(c, x, T, q2f + 1e-4, steps, alpha, height)
            j00, j10 = (a0 - r0) / 1e-4, (a1 - r1) / 1e-4
            j01, j11 = (b0 - r0) / 1e-4, (b1 - r1) / 1e-4
            det = j00 * j11 - j01 * j10
            if det == 0.0 or not math.isfinite(det):
                break
            dT = (-r0 * j11 + r1 * j01) / det
            dq = (-r1 * j00 + r0 * j10) / det
            T += min(0.5 * T, max(-0.5 * T, dT))
            q2f += min(0.3, max(-0.3, dq))
            if not 0.015 <= T <= 0.8:
                break
        if 0.015 <= T <= 0.8:
            if not done:
                r0, r1, acc = shoot(c, x, T, q2f, steps, alpha, height)
            if abs(r0) <= 0.05 and abs(r1) <= 0.005 and T >= min_time:
                return True, acc, T
    s = x[0] - alpha
    if -c[_L1] * math.cos(s) - c[_L2] * math.cos(s + x[1]) < height - hold_depth:
        return False, 0.0, 0.0   # no shot, and far from the aim: link 1 stopped early
    T, q2f = min_time, x[1]   # the last moments: T held, q2f only
    r1, acc = 0.0, 0.0
    for i in range(9):
        r0, r1, acc = shoot(c, x, T, q2f, steps, alpha, height)
        if i == 8 or abs(r1) < 1e-5:
            break
        slope = (shoot(c, x, T, q2f + 1e-4, steps, alpha, height)[1] - r1) / 1e-4
        if abs(slope) < 1e-6:
            return False, 0.0, 0.0
        q2f += min(0.3, max(-0.3, -r1 / slope))
    if abs(r1) < 0.002:
        return True, acc, T
    return False, 0.0, 0.0


@njit(cache=True)
def _driven(c, x, torque, duration, goal, period, substeps, tau_current):
    """(x, torque) after ``duration`` with the driver's current following
    ``goal`` at ``tau_current`` (its mean over each substep held; RK4)."""
    count = max(1, int(math.ceil(duration / period * substeps - 1e-9)))
    h = duration / count
    decay = math.exp(-h / tau_current)
    x0, x1, x2, x3 = x
    for _ in range(count):
        mean = goal + (torque - goal) * (1.0 - decay) * tau_current / h
        torque = goal + (torque - goal) * decay
        a0, a1, a2, a3 = rates(c, x0, x1, x2, x3, mean)
        b0, b1, b2, b3 = rates(c, x0 + 0.5 * h * a0, x1 + 0.5 * h * a1, x2 + 0.5 * h * a2,
                               x3 + 0.5 * h * a3, mean)
        d0, d1, d2, d3 = rates(c, x0 + 0.5 * h * b0, x1 + 0.5 * h * b1, x2 + 0.5 * h * b2,
                               x3 + 0.5 * h * b3, mean)
        e0, e1, e2, e3 = rates(c, x0 + h * d0, x1 + h * d1, x2 + h * d2, x3 + h * d3, mean)
        x0 = x0 + h / 6.0 * (a0 + 2.0 * b0 + 2.0 * d0 + e0)
        x1 = x1 + h / 6.0 * (a1 + 2.0 * b1 + 2.0 * d1 + e1)
        x2 = x2 + h / 6.0 * (a2 + 2.0 * b2 + 2.0 * d2 + e2)
        x3 = x3 + h / 6.0 * (a3 + 2.0 * b3 + 2.0 * d3 + e3)
    return (x0, x1, x2, x3), torque


@njit(cache=True)
def probe_rates(c, q1, q2, commands, steps, period, latency, driver, substeps):
    """The absolute link rates (N, 2) at ticks 1 .. N from rest at
    ``(q1, q2)`` with the command of tick k reaching the driver ``steps``
    ticks and ``latency`` s later (``driver``: torque limit, dead-band, the
    current loop's time constant), as
    :func:`~bplir_drake.systems.delay_id.probe_rates`."""
    n = commands.shape[0]
    limit, deadband, tau_current = driver[0], driver[1], driver[2]
    goals = np.zeros(n + steps + 2)   # the driver's target of command i - steps - 1
    for i in range(n):
        u = min(max(commands[i], -limit), limit)
        goals[i + steps + 1] = 0.0 if abs(u) < deadband else u
    x = (q1, q2, 0.0, 0.0)
    torque = 0.0
    out = np.empty((n, 2))
    for k in range(n):
        if latency > 0.0:
            x, torque = _driven(c, x, torque, latency, goals[k], period, substeps, tau_current)
        x, torque = _driven(c, x, torque, period - latency, goals[k + 1], period, substeps,
                            tau_current)
        out[k, 0], out[k, 1] = x[2], x[2] + x[3]
    return out
