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
from .imu import SAMPLER_WALK1, SAMPLER_WALK2, sample_kernel
from .nominal_kernel import predict
from .state import (ACCEL1_X, ACCEL1_Y, ACCEL2_X, ACCEL2_Y, GYRO1_Z, GYRO2_Z, OMEGA1, OMEGA2,
                    THETA1, THETA2)
from .tracker_kernel import TRACKER_COUNT, TRACKER_LATCH, TRACKER_PHASE, plan_tick

#: the offsets in the onboard computer's state :func:`front` reads (an
#: integer array in this order): the IMU sampler's state, the EKF's x, P,
#: previous accelerometer input and first-sample flag, the number of
#: filter states, the predictor's command buffer and its length (-1, 0
#: without a predictor)
AT = ("imu", "ekf_x", "ekf_P", "ekf_u", "ekf_first", "n", "predictor", "commands")
AT_IMU, AT_EKF_X, AT_EKF_P, AT_EKF_U, AT_EKF_FIRST, AT_N, AT_PREDICTOR, AT_COMMANDS = range(len(AT))

#: the onboard computer's record (its ``record`` output), by name and
#: length in this order: the estimate (relative), the command, the planned
#: q2, the IMU sample, the delay fit (zeros without an identifier), the
#: predicted state (the estimate without a predictor) and the delay in
#: ticks the tick compensated
RECORD_FIELDS = (("estimate", 4), ("command", 1), ("reference", 1), ("imu", 6),
                 ("delay_fit", 2), ("predicted", 4), ("delay_steps", 1))
REC_ESTIMATE, REC_COMMAND, REC_REFERENCE, REC_IMU, REC_DELAY_FIT, REC_PREDICTED, \
    REC_DELAY_STEPS = (sum(n for _, n in RECORD_FIELDS[:i]) for i in range(len(RECORD_FIELDS)))
RECORD_SIZE = sum(n for _, n in RECORD_FIELDS)


def record_slices() -> dict[str, slice]:
    """:data:`RECORD_FIELDS` as slices of the record, by name."""
    out, at = {}, 0
    for name, n in RECORD_FIELDS:
        out[name] = slice(at, at + n)
        at += n
    return out


@njit(cache=True)
def put(dst, at, src):
    """``dst[at:at + len(src)] = src``, element by element (a slice
    assignment compiles a shape check and its error message: seconds of a
    fresh install's first compile)."""
    for j in range(len(src)):
        dst[at + j] = src[j]


@njit(cache=True)
def relative(x):
    """The relative state (q1, q2, q1d, q2d) of the EKF's absolute ``x``
    (theta1, theta2, omega1, omega2, ...)."""
    rel = np.empty(4)
    rel[0], rel[1] = x[THETA1], x[THETA2] - x[THETA1]
    rel[2], rel[3] = x[OMEGA1], x[OMEGA2] - x[OMEGA1]
    return rel


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
    i = at[AT_IMU]
    imu = sample_kernel(r[GYRO1_Z], r[GYRO2_Z], r[ACCEL1_X], r[ACCEL1_Y], r[ACCEL2_X],
                        r[ACCEL2_Y], xd[i + SAMPLER_WALK1], xd[i + SAMPLER_WALK2], k, imu_c, draws)
    put(out, i, imu)
    xs, ps, us, n = at[AT_EKF_X], at[AT_EKF_P], at[AT_EKF_U], at[AT_N]
    x, P, u = step(xd[xs:xs + n], xd[ps:ps + n * n].reshape((n, n)), xd[us:us + 4],
                   imu[:6], xd[at[AT_EKF_FIRST]] > 0.5, hold, held, ekf_c, walk, cal)
    put(out, xs, x)
    put(out, ps, P.ravel())
    put(out, us, u)
    out[at[AT_EKF_FIRST]] = 0.0
    rel = relative(x)
    s0, length = at[AT_PREDICTOR], at[AT_COMMANDS]
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
    rel, state = front(xd, r, draws, k, imu_c, hold, held, ekf_c, walk, cal, pred_c, at, period,
                       m, out)
    i = at[AT_IMU]
    put(rec, REC_ESTIMATE, rel)
    put(rec, REC_IMU, out[i:i + 6])
    rec[REC_DELAY_FIT] = 0.0
    rec[REC_DELAY_FIT + 1] = 0.0
    put(rec, REC_PREDICTED, state)
    rec[REC_DELAY_STEPS] = steps
    if not track:
        return False, rel, state
    status, u, reference, tau = plan_tick(state, xd[tr + TRACKER_COUNT], xd[tr + TRACKER_LATCH],
                                          lead, period, t_end, t_final, x0s, u0s, Ks, k0s, rule,
                                          sc, c, probe)
    if status == 2:
        return False, rel, state
    out[tr + TRACKER_PHASE] = tau
    out[tr + TRACKER_COUNT] = xd[tr + TRACKER_COUNT] + 1.0
    out[tr + TRACKER_LATCH] = float(status)
    if at[AT_PREDICTOR] >= 0:
        out[at[AT_PREDICTOR] + at[AT_COMMANDS] - 1] = u
    rec[REC_COMMAND] = u
    rec[REC_REFERENCE] = reference
    return True, rel, state
