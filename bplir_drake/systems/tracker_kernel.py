"""The plan tracker's feedback law of one tick, compiled.

:func:`tracking_torque` is :meth:`~bplir_drake.systems.plan_tracker.PlanTracker.law`
off the terminal law: ``u0 - K (x - x0) - k0`` clipped to the motor's
torque window at the elbow rate (:func:`window`, the arithmetic of
:func:`~bplir_drake.systems.motor.torque_window_of`).  The gain's sum
``K (x - x0)`` is taken in one stated order and rounding
(:func:`gain_sum`), so it gives the same number on every machine."""
from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

from .nominal_kernel import elbow_torque, solve_shot


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (IEEE fused multiply-add)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        f = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(f, args)

    return sig, codegen


#: the plan tracker's state (:class:`~bplir_drake.systems.plan_tracker.PlanTracker`'s):
#: the plan phase of its last tick, its tick count and its terminal law's latch
TRACKER_FIELDS = ("phase", "count", "latch")
TRACKER_PHASE, TRACKER_COUNT, TRACKER_LATCH = range(len(TRACKER_FIELDS))


@njit(cache=True)
def gain_sum(K, d):
    """``sum_j K[j] d[j]``: the first product rounded, each next one fused
    into the running sum in index order (one rounding per term; the order
    and rounding of numpy's matrix product through x86 OpenBLAS)."""
    s = K[0] * d[0]
    for j in range(1, len(K)):
        s = fma(K[j], d[j], s)
    return s


def window_constants(motor, torque_limit: float) -> np.ndarray:
    """The constants of :func:`window`: (whether a motor bounds the torque,
    whether its voltage envelope does, torque per amp (N m/A), back-EMF per
    elbow rate (V s/rad), largest voltage (V), resistance (ohm), peak
    current (A), torque limit (N m)); ``motor`` None: the limit alone."""
    t_lim = float(torque_limit)
    if motor is None:
        return np.array([0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, t_lim])
    return np.array([1.0, float(bool(motor.envelope)), motor.torque_per_amp,
                     motor.back_emf_constant * motor.gear_ratio, motor.max_voltage,
                     motor.resistance, motor.i_peak, t_lim])


@njit(cache=True)
def _max(a, b):
    return b if b > a else a   # Python's max(a, b)


@njit(cache=True)
def _min(a, b):
    return b if b < a else a   # Python's min(a, b)


@njit(cache=True)
def window(q2d, c):
    """(lowest, highest) torque (N m) at the elbow rate ``q2d`` (rad/s)
    from the constants ``c`` of :func:`window_constants`."""
    t_lim = c[7]
    if c[0] == 0.0:
        return -t_lim, t_lim
    kt, i_lim = c[2], c[6]
    if c[1] != 0.0:
        e = c[3] * q2d
        lo, hi = (-c[4] - e) / c[5], (c[4] - e) / c[5]
    else:
        lo, hi = -np.inf, np.inf
    lo_t = _max(-t_lim, kt * _max(lo, -i_lim))
    return lo_t, _max(lo_t, _min(t_lim, kt * _min(hi, i_lim)))


@njit(cache=True)
def tracking_torque(x, x0, u0, K, k0, c):
    """The command (N m) at the state ``x`` for the plan's state ``x0``,
    torque ``u0``, gain row ``K`` and offset ``k0``: ``u0 - K (x - x0) - k0``
    clipped to :func:`window` at ``x[3]``."""
    d = np.empty(4)
    for j in range(4):
        d[j] = x[j] - x0[j]
    u = u0 - gain_sum(K, d) - k0
    lo, hi = window(x[3], c)
    return _min(_max(u, lo), hi)


@njit(cache=True)
def height(x, alpha, l1, l2):
    """The gripper's distance to the line (m, negative below it): the
    arithmetic of :func:`~bplir_drake.systems.landing.height_rates`."""
    s = x[0] - alpha
    th = s + x[1]
    return -l1 * math.cos(s) - l2 * math.cos(th)


@njit(cache=True)
def deceleration(x, c):
    """:meth:`~bplir_drake.systems.landing.Landing.deceleration` from its
    constants ``c``, in its arithmetic."""
    dc1, dc2, m11_0, m11_c, h_0, g1, g2, l1, rc2 = c[0], c[1], c[2], c[3], c[4], c[5], c[6], \
        c[7], c[8]
    q0, q1, v0, v1 = x[0], x[1], x[2], x[3]
    h = h_0 * math.sin(q1 + dc2)
    b0 = -h * (2.0 * v0 * v1 + v1 ** 2) + (
        g1 * math.sin(q0 + dc1) + g2 * (l1 * math.sin(q0) + rc2 * math.sin(q0 + q1 + dc2)))
    return b0 / (m11_0 + m11_c * math.cos(q1 + dc2))


@njit(cache=True)
def takes_over(x, rule):
    """The terminal law's ``takes_over(x)`` from its
    :func:`~bplir_drake.systems.landing.terminal_rule`."""
    kind = rule[0]
    if kind == 0.0:
        return False
    h = height(x, rule[1], rule[2], rule[3])
    if h > -rule[4]:
        return True
    if kind == 1.0:
        return False
    if h > -rule[5]:
        return True
    return deceleration(x, rule[8:17]) >= rule[6] and 0.0 <= x[2] < rule[7]


@njit(cache=True)
def shot_torque(x, rule, sc, lo, hi):
    """:meth:`~bplir_drake.systems.landing.ApexShot.torque` at ``x`` with the
    motor's window ``(lo, hi)``, from the shot's numbers in ``rule``
    (:func:`~bplir_drake.systems.landing.terminal_rule`) and its nominal
    model ``sc``, in its arithmetic: ``(found, torque)``, ``found`` False
    where no shot is solved (the caller runs the landing law)."""
    alpha, l1, l2 = rule[1], rule[2], rule[3]
    aim, hold_depth, give_up, brake, cap, gain = rule[18], rule[21], rule[22], rule[23], \
        rule[24], rule[25]
    if give_up > 0.0 and x[2] < -give_up and height(x, alpha, l1, l2) < aim:
        return True, elbow_torque(sc, x[0], x[1], x[2], x[3], -gain * (x[3] - 0.0))
    found, acc, _ = solve_shot(sc, x, int(rule[17]), alpha, aim, rule[19], rule[20], hold_depth)
    if not found:
        return False, 0.0
    u = elbow_torque(sc, x[0], x[1], x[2], x[3], acc)
    if brake > 0.0 and not (brake * lo <= u <= brake * hi):
        s = x[0] - alpha
        st = math.sin(s + x[1])
        if (l1 * math.sin(s) + l2 * st) * 0.0 + l2 * st * acc > 0:   # the elbow lifts it
            return True, elbow_torque(sc, x[0], x[1], x[2], x[3], -gain * (x[3] - 0.0))
    v2 = x[3]
    if cap <= 0.0 or abs(v2) <= cap or height(x, alpha, l1, l2) <= aim - hold_depth:
        return True, u
    s = math.copysign(1.0, v2)
    ub = elbow_torque(sc, x[0], x[1], x[2], x[3], -gain * (x[3] - s * cap))
    return True, (ub if (u - ub) * s > 0.0 else u)


@njit(cache=True)
def plan_tick(x, k, reached, lead, period, t_end, t_final, x0s, u0s, Ks, k0s, rule, sc, c,
              probe):
    """A time-indexed tick of the plan tracker at the state ``x``, tick
    ``k`` (a count held as a float), the terminal law's latch ``reached``
    and the ``lead`` (s): ``(status, torque, planned q2, tau)``, the torque
    and q2 from the plan's rows at the ticks (``x0s``, ``u0s``, ``Ks``,
    ``k0s``: row ``i`` the plan at ``i period + lead``, its last at the
    plan's end) with the delay probe's torques added.  ``status`` 0: the
    plan's law; 1: the terminal law ``rule`` (the apex shot, on its nominal
    model ``sc``) took over; 2: it took over and is left to the caller (a
    law other than the shot, or no shot solved)."""
    tau = k * period + lead
    i = int(k + 0.5)
    row = min(i, len(u0s) - 1)
    status = 0
    if rule[0] != 0.0 and (reached > 0.5 or tau >= t_end
                           or (tau > t_final and takes_over(x, rule))):
        if rule[0] != 3.0:
            return 2, 0.0, 0.0, tau
        lo, hi = window(x[3], c)
        found, u = shot_torque(x, rule, sc, lo, hi)
        if not found:
            return 2, 0.0, 0.0, tau
        u, status = _min(_max(u, lo), hi), 1
    else:
        u = tracking_torque(x, x0s[row], u0s[row], Ks[row], k0s[row], c)
    if i < len(probe):
        lo, hi = window(x[3], c)
        u = _min(_max(u + probe[i], lo), hi)
    return status, u, x0s[row, 1], tau
