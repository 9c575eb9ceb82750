"""The compiled onboard computer's tick: the IMU sample, the EKF's step, the
delay predictor's prediction (:func:`front`) and the plan tracker's
time-indexed tick (:func:`tick`) in one call.

It calls the parts' own kernels (:func:`~bplir_drake.systems.imu.sample_kernel`,
:func:`~bplir_drake.systems.ekf_kernel.step`,
:func:`~bplir_drake.systems.nominal_kernel.predict`,
:func:`~bplir_drake.systems.tracker_kernel.plan_tick`) with the arguments
their systems pass, so it computes the same numbers, bit for bit; what it
saves is the crossings between Python and compiled code and the arrays
made between them."""
from __future__ import annotations

import numpy as np
from numba import njit

from .ekf_kernel import step
from .imu import sample_kernel
from .nominal_kernel import predict
from .tracker_kernel import plan_tick

#: the offsets in the onboard computer's state :func:`front` reads (an
#: integer array in this order): the IMU sampler's state, the EKF's x, P,
#: previous accelerometer input and first-sample flag, the number of
#: filter states, the predictor's command buffer and its length (-1, 0
#: without a predictor)
AT = ("imu", "ekf_x", "ekf_P", "ekf_u", "ekf_first", "n", "predictor", "commands")


@njit(cache=True)
def put(dst, at, src):
    """``dst[at:at + len(src)] = src``, element by element (a slice
    assignment compiles a shape check and its error message: seconds of a
    fresh install's first compile)."""
    for j in range(len(src)):
        dst[at + j] = src[j]


@njit(cache=True)
def front(xd, r, draws, k, imu_c, hold, held, ekf_c, walk, cal, pred_c, at, period, m, out):
    """The tick's IMU sample, filter step and prediction from the stored
    state ``xd`` and the ideal readings ``r`` (12: gyro1, gyro2, accel1,
    accel2): ``out`` (``xd``'s length) is set to ``xd`` with the sampler's
    and the EKF's parts stepped and the predictor's buffer shifted by one
    (its last entry, this tick's command, is the caller's to write);
    returns (the estimate relative, the state the tracker reads: the
    prediction over the buffer's last ``m`` commands with a predictor, else
    the estimate).  ``k``, ``draws``: the sample's index and its noise
    draws; ``hold``: whether the filter still holds its calibration;
    ``at``: the offsets of :data:`AT`."""
    put(out, 0, xd)
    i = at[0]
    imu = sample_kernel(r[2], r[5], r[6], r[7], r[9], r[10], xd[i + 6], xd[i + 7], k,
                        imu_c, draws)
    put(out, i, imu)
    xs, ps, us, n = at[1], at[2], at[3], at[5]
    x, P, u = step(xd[xs:xs + n], xd[ps:ps + n * n].reshape((n, n)), xd[us:us + 4],
                   imu[:6], xd[at[4]] > 0.5, hold, held, ekf_c, walk, cal)
    put(out, xs, x)
    put(out, ps, P.ravel())
    put(out, us, u)
    out[at[4]] = 0.0
    rel = np.empty(4)
    rel[0], rel[1], rel[2], rel[3] = x[0], x[1] - x[0], x[2], x[3] - x[2]
    s0, length = at[6], at[7]
    if s0 < 0:
        return rel, rel
    state = predict(pred_c, rel, xd[s0 + length - m:s0 + length], period, 2)
    put(out, s0, xd[s0 + 1:s0 + length])
    return rel, state


@njit(cache=True)
def tick(xd, r, draws, k, imu_c, hold, held, ekf_c, walk, cal, pred_c, at, period, m, out, rec,
         steps, track, tr, lead, t_end, t_final, x0s, u0s, Ks, k0s, rule, sc, c, probe):
    """:func:`front`, then with ``track`` the plan tracker's time-indexed
    tick on the state it gives (:func:`~bplir_drake.systems.tracker_kernel.plan_tick`:
    the tracker's stored phase, count and latch at ``xd[tr:tr + 3]``, its
    ``lead``, plan ends and rows): ``out`` as :func:`front` sets it and
    ``rec`` (the onboard computer's record, 19) set but for the delay fit
    (zeros); where the tracker ticked, ``out``'s tracker part, the
    predictor's last command and the record's command and planned q2 too.
    Returns (whether the tracker ticked -- not where a terminal law other
    than the apex shot takes over, or no shot is solved, or without
    ``track``: the caller ticks it --, the estimate relative, the state the
    tracker reads)."""
    relative, state = front(xd, r, draws, k, imu_c, hold, held, ekf_c, walk, cal, pred_c, at,
                            period, m, out)
    i = at[0]
    put(rec, 0, relative)
    put(rec, 6, out[i:i + 6])
    rec[12] = 0.0
    rec[13] = 0.0
    put(rec, 14, state)
    rec[18] = steps
    if not track:
        return False, relative, state
    status, u, reference, tau = plan_tick(state, xd[tr + 1], xd[tr + 2], lead, period, t_end,
                                          t_final, x0s, u0s, Ks, k0s, rule, sc, c, probe)
    if status == 2:
        return False, relative, state
    out[tr] = tau
    out[tr + 1] = xd[tr + 1] + 1.0
    out[tr + 2] = float(status)
    if at[6] >= 0:
        out[at[6] + at[7] - 1] = u
    rec[4] = u
    rec[5] = reference
    return True, relative, state
