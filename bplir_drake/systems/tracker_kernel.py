"""The plan tracker's feedback law of one tick, compiled.

:func:`tracking_torque` is :meth:`~bplir_drake.systems.plan_tracker.PlanTracker.law`
off the terminal law: ``u0 - K (x - x0) - k0`` clipped to the motor's
torque window at the elbow rate (:func:`window`, the arithmetic of
:func:`~bplir_drake.systems.motor.torque_window_of`).  The gain's sum
``K (x - x0)`` is taken in one stated order and rounding
(:func:`gain_sum`), so it gives the same number on every machine."""
from __future__ import annotations

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic


@intrinsic
def fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (IEEE fused multiply-add)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        f = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(f, args)

    return sig, codegen


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
