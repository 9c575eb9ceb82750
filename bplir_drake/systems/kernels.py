"""The compiled kernels of the 100 Hz chain, loaded at once.

Each kernel (numba, ``njit(cache=True)``) is compiled on its first call in a
fresh install and loaded from its cache in later processes; the first call
in a process also starts numba's compiler (about 0.3 s).  A process that
forks workers calls :func:`warm_up` first, so that its workers inherit the
kernels ready instead of each loading them."""
from __future__ import annotations

import numpy as np

from ..params import preset
from . import ekf_kernel, gripper, imu, nominal_kernel, onboard_kernel, tracker_kernel
from .state import ACCEL1_Y, ACCEL2_Y, ImuReadings


def read_only(a) -> np.ndarray:
    """``a`` as a read-only float array, without a copy where it already is
    one: the systems pass Drake's state vectors, which numpy sees read-only,
    and a kernel is compiled once per writability of its arguments, so
    every caller passes the same."""
    a = np.asarray(a, dtype=float)
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a


def warm_up(group: str = "all") -> None:
    """Call every kernel once with the argument types the systems pass
    (the default swing's), loading or compiling each in this process.
    ``group``: ``"filter"`` the EKF step, then the onboard computer's tick
    that calls it; ``"others"`` the rest, those the tick calls first; two
    processes can each compile one group at once on a fresh install."""
    p = preset().resolved()
    if group in ("others", "all"):
        _others(p)
    if group in ("filter", "all"):
        _filter(p)


def _others(p) -> None:
    c = nominal_kernel.pack(p.plant, p.friction)
    x = np.array([0.1, 0.2, 0.5, 0.1])
    nominal_kernel.predict(c, x, read_only(np.zeros(1)), 0.01, 2)
    imu.sample_kernel(0.0, 0.0, 0.0, 9.8, 0.0, 9.8, 0.0, 0.0, 0, imu.pack(p.imu),
                      read_only(np.zeros(8)))
    wc = tracker_kernel.window_constants(p.motor, 20.0)
    tracker_kernel.tracking_torque(x, x, 0.0, x, 0.0, wc)
    rows = np.zeros((3, 4))
    tracker_kernel.plan_tick(x, 0.0, 0.0, 0.0, 0.01, 1.0, 0.5, rows, np.zeros(3), rows,
                             np.zeros(3), np.zeros(26), c, wc, np.zeros(2))
    nominal_kernel.solve_shot(c, x, 12, 0.0, -0.01, 0.1, 0.04, 0.03)
    nominal_kernel.elbow_torque(c, 0.1, 0.2, 0.3, 0.4, 1.0)
    nominal_kernel.probe_rates(c, 0.1, 0.2, np.zeros(2), 1, 0.01, 0.0,
                               np.array([20.0, 0.1, 0.001]), 2)
    gripper.interlock_update(np.zeros(len(gripper.STATE_FIELDS)), np.zeros(4), 0.0, 0.01,
                             np.array([0.9, 0.9, 0.0, 1.2]), 0.02, 0.6, 0.0, np.zeros(4), 0.0,
                             5.0, 4.0, 3.0)


def _filter(p) -> None:
    consts, walk = ekf_kernel.pack(p.estimator)
    n = len(walk)
    ekf_kernel.step(read_only(np.zeros(n)), read_only(np.eye(n)), read_only(np.zeros(4)),
                    np.array([0.0, 0.0, 0.0, 9.8, 0.0, 9.8]), True, False, False, consts, walk,
                    np.zeros(4))
    # the onboard computer's state: the EKF's x, P, u and flag, the tracker's
    # three, a predictor's two commands, the sampler's nine; the readings at rest
    ok = onboard_kernel
    n_tr, n_imu, commands = len(tracker_kernel.TRACKER_FIELDS), len(imu.SAMPLER_FIELDS), 2
    xd = np.zeros(n + n * n + 4 + 1 + n_tr + commands + n_imu)
    xd[n:n + n * n] = np.eye(n).ravel()
    tr = n + n * n + 5
    at = np.zeros(len(ok.AT), dtype=np.int64)
    at[ok.AT_IMU], at[ok.AT_EKF_X], at[ok.AT_EKF_P] = len(xd) - n_imu, 0, n
    at[ok.AT_EKF_U], at[ok.AT_EKF_FIRST], at[ok.AT_N] = n + n * n, n + n * n + 4, n
    at[ok.AT_PREDICTOR], at[ok.AT_COMMANDS] = tr + n_tr, commands
    readings = np.zeros(len(ImuReadings._fields))
    readings[[ACCEL1_Y, ACCEL2_Y]] = 9.8
    rows = np.zeros((3, 4))
    onboard_kernel.tick(read_only(xd), readings, read_only(np.zeros(8)), 0, imu.pack(p.imu),
                        False, False, consts, walk, np.zeros(4),
                        nominal_kernel.pack(p.plant, p.friction), at, 0.01, 2,
                        np.empty(len(xd)), np.empty(ok.RECORD_SIZE), 0.0, True, tr, 0.0, 1.0,
                        0.5, rows,
                        np.zeros(3), rows, np.zeros(3), np.zeros(26),
                        nominal_kernel.pack(p.plant, p.friction),
                        tracker_kernel.window_constants(p.motor, 20.0), np.zeros(2))
