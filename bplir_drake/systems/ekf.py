"""Kinematic extended Kalman filter (chapter 5) as a discrete Drake system.

State ``(theta1, theta2, omega1, omega2[, b1, b2][, eps1, eps2][, k1, k2])``
in absolute angles, with optional gyro-bias states (the dissertation's
recommended extension) and self-calibration states (issue 20): each
accelerometer's mounting misalignment ``eps_i`` and each gyro's scale error
``k_i``, and each IMU's distance ``r_i`` along its link (:func:`state_layout`).

Misalignment: a sample is rotated back by the current estimate of
``eps_i`` before the step (as :meth:`ImuCalibration.correct` does with a
standstill calibration).  A remaining error ``d = eps_i - eps_hat_i``
leaves the corrected radial reading ``mu_y - d mu_x`` and the tangential
input ``mu_x + d mu_y`` (first order), which gives the misalignment columns
of the update and transition Jacobians (:func:`misalignment_columns`).
Gravity turns with the link angle *and* the misalignment, the centripetal
and tangential terms with the misalignment only: while the links swing,
both are observable (:mod:`bplir_drake.analysis.estimation.observability`).
A gyro reads ``(1 + k_i) omega_i + b_i``.
Prediction (5.10) discretised by explicit Euler (5.3) with the measured
tangential accelerations ``u = (mu_x1, mu_x2)`` as inputs; measurement
``z = (gyro1, gyro2, mu_y1, mu_y2)`` (5.11)-(5.12).  The filter uses geometry
only (``r1``, ``r2``, ``l1``, ``g``): no mass, inertia or friction.

Jacobians are derived from the model functions in closed form and tested
against AutoDiffXd (:func:`jacobians`), never typed from the printed
(5.15)/(5.28).  Erratum: the printed output ``e`` of (5.11)
carries a spurious factor ``l1/r1`` on the centripetal term ``omega2^2 r2``;
the measurement model here is derived from (5.6)-(5.9) (see
:func:`bplir_drake.systems.imu.imu_kinematics`) and tested against the
simulated IMUs.

Process noise enters through the accelerometer inputs:
``W = d f_d / d u = Ts d f / d u`` with ``Q = sigma_mu^2 I`` ((5.26), (5.39));
measurement noise ``R = diag(sigma_w^2, sigma_w^2, sigma_mu^2, sigma_mu^2)``
((5.34), (5.39)-(5.40)).  The covariance update uses the Joseph form.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache, wraps

import numpy as np
import pydrake.math as dmath
from pydrake.autodiffutils import AutoDiffXd, ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem

from ..params import EstimatorParams
from .calibration import ImuCalibration
from .line_sensor import line_gap
from .schedule import declare_store, declare_tick_result


# ----------------------------------------------------------- model functions

def _per_block(fun):
    """``fun(p)`` cached per parameter block: by identity first (the filter
    passes the same block every tick, and hashing a frozen dataclass of
    forty fields costs more than the filter's arithmetic), then by value
    (``lru_cache``)."""
    by_value = lru_cache(maxsize=64)(fun)
    last = [None, None]   # (block, value) of the last call

    @wraps(fun)
    def cached(p):
        if last[0] is not p:
            last[:] = p, by_value(p)
        return last[1]

    cached.cache_clear = by_value.cache_clear
    return cached


@lru_cache(maxsize=16)
def _identity(n: int) -> np.ndarray:
    """The n x n identity (read-only, shared)."""
    eye = np.eye(n)
    eye.flags.writeable = False
    return eye


@_per_block
def state_layout(p: EstimatorParams) -> tuple[dict, int]:
    """({group: slice} of the optional states, state size): ``"bias"`` (gyro
    biases), ``"misalign"`` (accelerometer misalignments), ``"scale"``
    (gyro scale errors), ``"position"`` (the IMUs' distances r1, r2 along
    their links), each 2 wide and in this order after the 4 angles and
    rates, when the parameters turn them on."""
    layout, n = {}, 4
    for on, name in ((p.estimate_bias, "bias"), (p.estimate_misalignment, "misalign"),
                     (p.estimate_gyro_scale, "scale"), (p.estimate_imu_position, "position")):
        if on:
            layout[name] = slice(n, n + 2)
            n += 2
    return layout, n


#: per optional state group: the EstimatorParams fields of its prior
#: standard deviation and its random walk (per sqrt(s))
GROUP_NOISE = {"bias": ("bias_sigma0", "bias_walk"),
               "misalign": ("misalign_sigma0", "misalign_walk"),
               "scale": ("gyro_scale_sigma0", "gyro_scale_walk"),
               "position": ("imu_position_sigma0", "imu_position_walk")}


def _pair(x, p: EstimatorParams, group: str, default):
    """The two states of ``group`` in ``x``, or ``default`` when not estimated."""
    sl = state_layout(p)[0].get(group)
    return (x[sl.start], x[sl.start + 1]) if sl and len(x) >= sl.stop else default


def _gyro_terms(x, p: EstimatorParams):
    """(bias, scale error) per gyro from the state (zeros when not estimated)."""
    return _pair(x, p, "bias", (0.0, 0.0)), _pair(x, p, "scale", (0.0, 0.0))


def imu_radii(x, p: EstimatorParams):
    """(r1, r2): the IMU distances of the state, or the geometry's."""
    return _pair(x, p, "position", (p.r1, p.r2))


def kinematic_f(x, u, p: EstimatorParams):
    """Continuous kinematic model (5.10); ``x`` may carry bias states."""
    t1, t2, w1, w2 = x[0], x[1], x[2], x[3]
    s1, s2 = dmath.sin(t1), dmath.sin(t2)
    s21, c21 = dmath.sin(t2 - t1), dmath.cos(t2 - t1)
    r1, r2 = imu_radii(x, p)
    a1 = (u[0] - p.g * s1) / r1
    a2 = (-p.l1 * c21 * a1 + u[1] - p.g * s2 - p.l1 * w1 ** 2 * s21) / r2
    out = [w1, w2, a1, a2]
    out += [0.0 * x[i] for i in range(4, len(x))]  # biases: random walk
    return np.array(out)


def kinematic_h(x, u, p: EstimatorParams):
    """Measurement model: gyro rates (+ bias) and the radial specific forces."""
    t1, t2, w1, w2 = x[0], x[1], x[2], x[3]
    c1, c2 = dmath.cos(t1), dmath.cos(t2)
    s21, c21 = dmath.sin(t2 - t1), dmath.cos(t2 - t1)
    r1, r2 = imu_radii(x, p)
    a1 = (u[0] - p.g * dmath.sin(t1)) / r1
    (b1, b2), (k1, k2) = _gyro_terms(x, p)
    return np.array([
        (1.0 + k1) * w1 + b1,
        (1.0 + k2) * w2 + b2,
        r1 * w1 ** 2 + p.g * c1,
        p.l1 * (-a1 * s21 + w1 ** 2 * c21) + r2 * w2 ** 2 + p.g * c2,
    ])


def kinematic_h_printed(x, u, p: EstimatorParams):
    """(5.11) exactly as printed (with the l1/r1 factor on omega2^2 r2), for
    documenting the erratum only."""
    t1, t2, w1, w2 = x[0], x[1], x[2], x[3]
    c1, c2 = math.cos(t1), math.cos(t2)
    s21, c21 = math.sin(t2 - t1), math.cos(t2 - t1)
    k = p.l1 / p.r1
    e = (k * c21 * (w1 ** 2 * p.r1 + p.g * c1) + k * w2 ** 2 * p.r2
         + (1 - k) * p.g * c2 - k * s21 * u[0])
    return np.array([w1, w2, w1 ** 2 * p.r1 + p.g * c1, e])


def jacobians(fun, x, u, p: EstimatorParams):
    """(value, d/dx, d/du) of ``fun(x, u, p)`` by forward AutoDiff."""
    n = len(x)
    xu = InitializeAutoDiff(np.concatenate([x, u]))[:, 0]
    val = fun(xu[:n], xu[n:], p)
    val = np.array([v if isinstance(v, AutoDiffXd) else AutoDiffXd(float(v)) for v in val])
    J = ExtractGradient(val)
    if J.shape[1] != n + len(u):  # constant outputs carry empty gradients
        J = np.array([v.derivatives() if v.derivatives().size else np.zeros(n + len(u))
                      for v in val])
    return ExtractValue(val)[:, 0], J[:, :n], J[:, n:]


# ----------------------------------------------------------- the filter step

@dataclass
class EkfState:
    """The filter's state estimate x (n) and covariance P (n, n)."""
    x: np.ndarray   # (n,)
    P: np.ndarray   # (n, n)


@_per_block
def noise_matrices(p: EstimatorParams):
    """(Q_u (2x2) on the accelerometer inputs, R (4x4)); cached per
    parameter block (read-only arrays).  The optional states' random walks:
    :func:`_walk_variances`."""
    Qu = p.accel_process_sigma ** 2 * np.eye(2)
    R = np.diag([p.gyro_meas_sigma ** 2] * 2 + [p.accel_meas_sigma ** 2] * 2)
    Qu.flags.writeable = R.flags.writeable = False
    return Qu, R


@_per_block
def _input_noises(p: EstimatorParams) -> dict:
    """{inputs per prediction: their noise covariance}: Q_u for one
    2-vector, and for both ends of a period (4) independent noise on each
    (read-only arrays)."""
    Qu, _ = noise_matrices(p)
    both = np.kron(np.eye(2), Qu)
    both.flags.writeable = False
    return {2: Qu, 4: both}


def initial_state(p: EstimatorParams, x0, sigmas=None) -> EkfState:
    """Initial filter state; ``sigmas`` = (angle, rate[, bias]) overrides p0."""
    layout, n = state_layout(p)
    x = np.zeros(n)
    if "position" in layout:
        x[layout["position"]] = (p.r1, p.r2)
    x0 = np.asarray(x0, dtype=float)
    x[:min(n, len(x0))] = x0[:n]
    a, r, b = (tuple(sigmas) + (p.bias_sigma0,))[:3] if sigmas is not None else \
        (p.p0_angle, p.p0_rate, p.bias_sigma0)
    sd = [a] * 2 + [r] * 2
    for group in layout:   # in state order
        sd += [b if group == "bias" else getattr(p, GROUP_NOISE[group][0])] * 2
    return EkfState(x, np.diag(np.square(sd)))


def input_ends(u):
    """(input at the start, input at the end) of a period: ``u`` is either
    both ends stacked (4: the ``"heun"`` prediction input) or one 2-vector
    held over the period (a missing sample, or the other integrations)."""
    return (u[:2], u[2:4]) if len(u) == 4 else (u, u)


def discrete_f(x, u, p: EstimatorParams):
    """One period of (5.10): explicit Euler (5.3), or with ``integration =
    "trapezoid"`` a second-order step for the angles
    ``theta + T omega + T^2/2 omega'`` (the Euler angle update is the
    rectangle rule, which drifts during the fast elbow motion of a swing),
    or with ``"heun"`` Heun's second-order step for the whole state, with
    the accelerations measured at both ends of the period
    (:func:`prediction_input`).  The trapezoid step still takes gravity's
    part of ``omega'`` at the start of the period: a first-order error
    (about ``g cos(theta) omega T^2 / (2 r)`` per step) that a
    self-calibrating filter reads as a gyro scale error of 0.2-0.3 % and
    misalignments of 0.03-0.08 deg on a noise-free log; Heun's step
    removes it."""
    Ts = p.period
    if p.integration == "heun":
        u0, u1 = input_ends(u)
        k1 = kinematic_f(x, u0, p)
        k2 = kinematic_f(x + Ts * k1, u1, p)
        return x + 0.5 * Ts * (k1 + k2)
    f = kinematic_f(x, u, p)
    out = x + Ts * f
    if p.integration == "trapezoid":
        out = np.array([out[0] + 0.5 * Ts * Ts * f[2], out[1] + 0.5 * Ts * Ts * f[3],
                        *out[2:]])
    return out


def kinematic_f_jacobians(x, u, p: EstimatorParams):
    """(f, df/dx, df/du) of :func:`kinematic_f` in closed form (plain floats;
    tested against AutoDiff)."""
    n = len(x)
    t1, t2, w1 = float(x[0]), float(x[1]), float(x[2])
    s1, c1, s2, c2 = math.sin(t1), math.cos(t1), math.sin(t2), math.cos(t2)
    s21, c21 = math.sin(t2 - t1), math.cos(t2 - t1)
    r1, r2 = (float(r) for r in imu_radii(x, p))
    a1 = (u[0] - p.g * s1) / r1
    a1_t1 = -p.g * c1 / r1
    l1 = p.l1
    a2 = (-l1 * c21 * a1 + u[1] - p.g * s2 - l1 * w1 * w1 * s21) / r2
    f = np.zeros(n)
    f[:4] = (w1, x[3], a1, a2)
    A = np.zeros((n, n))
    A[0, 2] = A[1, 3] = 1.0
    A[2, 0] = a1_t1
    A[3, 0] = (-l1 * s21 * a1 - l1 * c21 * a1_t1 + l1 * w1 * w1 * c21) / r2
    A[3, 1] = (l1 * s21 * a1 - p.g * c2 - l1 * w1 * w1 * c21) / r2
    A[3, 2] = -2.0 * l1 * w1 * s21 / r2
    B = np.zeros((n, 2))
    B[2, 0] = 1.0 / r1
    B[3, 0] = -l1 * c21 / (r1 * r2)
    B[3, 1] = 1.0 / r2
    layout, _ = state_layout(p)
    if "position" in layout and n >= layout["position"].stop:
        m = layout["position"].start
        A[2, m] = -a1 / r1
        A[3, m] = l1 * c21 * a1 / (r1 * r2)
        A[3, m + 1] = -a2 / r2
    return f, A, B


def discrete_f_jacobians(x, u, p: EstimatorParams):
    """(x_next, A = df_d/dx, W = df_d/du) of :func:`discrete_f` in closed form
    (``W`` has a column per input: 4 for a ``"heun"`` input with both ends)."""
    Ts = p.period
    x = np.asarray(x, dtype=float)
    if p.integration == "heun":
        u0, u1 = input_ends(u)
        f1, J1, B1 = kinematic_f_jacobians(x, u0, p)
        f2, J2, B2 = kinematic_f_jacobians(x + Ts * f1, u1, p)
        eye = np.eye(len(x))
        A = eye + 0.5 * Ts * (J1 + J2 @ (eye + Ts * J1))
        W0, W1 = 0.5 * Ts * (B1 + Ts * J2 @ B1), 0.5 * Ts * B2
        return x + 0.5 * Ts * (f1 + f2), A, (np.hstack([W0, W1]) if len(u) == 4 else W0 + W1)
    f, Jx, Ju = kinematic_f_jacobians(x, u, p)
    x_new = x + Ts * f
    A = _identity(len(x)) + Ts * Jx
    W = Ts * Ju
    if p.integration == "trapezoid":
        h = 0.5 * Ts * Ts
        x_new[0:2] += h * f[2:4]
        A[0:2] += h * Jx[2:4]
        W[0:2] += h * Ju[2:4]
    return x_new, A, W


def kinematic_h_jacobian(x, u, p: EstimatorParams):
    """(h, dh/dx) of :func:`kinematic_h` in closed form (tested against AutoDiff)."""
    n = len(x)
    t1, t2, w1, w2 = (float(v) for v in x[:4])
    s1, c1, s2, c2 = math.sin(t1), math.cos(t1), math.sin(t2), math.cos(t2)
    s21, c21 = math.sin(t2 - t1), math.cos(t2 - t1)
    r1, r2 = (float(r) for r in imu_radii(x, p))
    a1 = (u[0] - p.g * s1) / r1
    a1_t1 = -p.g * c1 / r1
    l1 = p.l1
    layout, _ = state_layout(p)
    (b1, b2), (k1, k2) = _gyro_terms(x, p)
    h = np.array([(1.0 + k1) * w1 + b1, (1.0 + k2) * w2 + b2, r1 * w1 * w1 + p.g * c1,
                  l1 * (-a1 * s21 + w1 * w1 * c21) + r2 * w2 * w2 + p.g * c2])
    H = np.zeros((4, n))
    H[0, 2], H[1, 3] = 1.0 + k1, 1.0 + k2
    if "bias" in layout and n >= layout["bias"].stop:
        H[0, layout["bias"].start] = H[1, layout["bias"].start + 1] = 1.0
    if "scale" in layout and n >= layout["scale"].stop:
        H[0, layout["scale"].start], H[1, layout["scale"].start + 1] = w1, w2
    H[2, 0] = -p.g * s1
    H[2, 2] = 2.0 * r1 * w1
    H[3, 0] = l1 * (-a1_t1 * s21 + a1 * c21 + w1 * w1 * s21)
    H[3, 1] = l1 * (-a1 * c21 - w1 * w1 * s21) - p.g * s2
    H[3, 2] = 2.0 * l1 * w1 * c21
    H[3, 3] = 2.0 * r2 * w2
    if "position" in layout and n >= layout["position"].stop:
        m = layout["position"].start
        H[2, m] = w1 * w1
        H[3, m] = l1 * s21 * a1 / r1
        H[3, m + 1] = w2 * w2
    return h, H


@_per_block
def _walk_variances(p: EstimatorParams) -> np.ndarray:
    """Per-second random-walk variances of the optional states (layout order)."""
    layout, n = state_layout(p)
    q = np.zeros(n)
    for group, sl in layout.items():
        q[sl] = getattr(p, GROUP_NOISE[group][1]) ** 2
    q.flags.writeable = False
    return q


def misalignment_columns(radial, W) -> np.ndarray:
    """d(.)/d eps (rows, 2) of a quantity that depends on the tangential
    inputs through ``W = d(.)/du`` (rows, 2; or 4 for inputs at both ends of
    a period, with ``radial`` of 4 to match): the corrected tangential
    reading is ``mu_x + d mu_y`` for a misalignment error ``d``, so the
    true input is the corrected one less ``d mu_y`` (``radial``: the
    corrected radial readings)."""
    cols = -np.asarray(W) * np.asarray(radial, dtype=float)[None, :]
    return cols[:, :2] + cols[:, 2:] if cols.shape[1] == 4 else cols


def ekf_predict(s: EkfState, u, p: EstimatorParams, *, with_jacobian: bool = False,
                radial=None):
    """(5.23)-(5.24): prediction over one period; ``A = df_d/dx`` and
    ``W = df_d/du`` in closed form (:func:`discrete_f_jacobians`).  With
    misalignment states, ``radial`` (the corrected radial readings paired
    with ``u``) gives their transition columns.  With ``with_jacobian``
    returns ``(state, A)`` (for a smoother)."""
    layout, _ = state_layout(p)
    x_new, A, W = discrete_f_jacobians(s.x, np.asarray(u, dtype=float), p)
    if "misalign" in layout and radial is not None:
        A[:, layout["misalign"]] += misalignment_columns(radial, W)
    Qu = _input_noises(p)[W.shape[1]]   # 4: independent noise on the readings at both ends
    P = A @ s.P @ A.T + (W @ Qu) @ W.T
    P.flat[::P.shape[0] + 1] += _walk_variances(p) * p.period   # the diagonal
    return (EkfState(x_new, P), A) if with_jacobian else EkfState(x_new, P)


def ekf_update(s: EkfState, z, u, p: EstimatorParams, *, with_innovation: bool = False,
               hold: bool = False, hold_misalign: bool = False):
    """(5.29)-(5.31), Joseph form.  ``z`` and ``u`` are the sample corrected
    by the state's misalignment estimate (:func:`correct_sample`); with
    misalignment states the radial rows get their columns ``-mu_x`` (and
    the elbow IMU's row its dependence on link 1's tangential input).  With
    ``hold`` the states beyond the angles and rates are considered but not
    updated (their gain rows zeroed: the Schmidt-Kalman filter; the Joseph
    form keeps the covariance right for any gain), as while the angles
    converge from a start far off, where a filter would otherwise explain
    its angle error by biases and misalignments; ``hold_misalign`` holds the
    misalignment states alone.  With ``p.inflate_nis``
    a prediction whose innovation is too large for it is inflated first
    (:class:`~bplir_drake.params.EstimatorParams`).  With
    ``with_innovation`` returns ``(state, innovation, its covariance S
    before any inflation, the prediction the update used)`` (for
    consistency checks and the smoother's backward pass)."""
    layout, _ = state_layout(p)
    u = np.asarray(u, dtype=float)
    h, H = kinematic_h_jacobian(s.x, u, p)
    if "misalign" in layout:
        m = layout["misalign"].start
        H[2, m] -= u[0]
        H[3, m + 1] -= u[1]
        # h_y2 reads link 1's tangential input, which is off by -d mu_y1
        # (d h_y2 / d u1 = -l1 sin(t2 - t1) / r1)
        H[3, m] += p.l1 * math.sin(s.x[1] - s.x[0]) / imu_radii(s.x, p)[0] * z[2]
    _, R = noise_matrices(p)
    PHt = s.P @ H.T
    S = H @ PHt + R
    nu = np.asarray(z, dtype=float) - h
    S_raw = S
    if p.inflate_nis > 0.0:   # covariance inflation (params doc)
        excess = float(nu @ np.linalg.solve(S, nu)) / (p.inflate_nis * len(nu))
        if excess > 1.0:
            s = EkfState(s.x, s.P * excess)
            PHt = s.P @ H.T
            S = H @ PHt + R
    K = np.linalg.solve(S, PHt.T).T
    held = _held_states(p) if hold else None
    if held is not None:   # Schmidt: considered, not updated, while the angles converge
        K[held] = 0.0
    if hold_misalign and "misalign" in layout:
        K[layout["misalign"]] = 0.0
    x = s.x + K @ nu
    IKH = _identity(len(s.x)) - K @ H
    P = IKH @ s.P @ IKH.T + K @ R @ K.T
    out = EkfState(x, 0.5 * (P + P.T))
    return (out, nu, S_raw, s) if with_innovation else out


def ekf_gap_update(s: EkfState, reading: float, line) -> EkfState:
    """The update with a line range sensor's reading (m, the free gripper's
    distance below the line): ``line = (l1, l2, alpha, sigma)``, the
    nominal link lengths, the line's incline and the reading's noise
    (:func:`~bplir_drake.systems.line_sensor.line_gap`); scalar, Joseph
    form."""
    l1, l2, alpha, sigma = line
    gap, d1, d2 = line_gap(s.x[0], s.x[1], l1, l2, alpha)
    H = np.zeros(len(s.x))
    H[0], H[1] = d1, d2
    PHt = s.P @ H
    K = PHt / (H @ PHt + sigma * sigma)
    x = s.x + K * (reading - gap)
    IKH = _identity(len(s.x)) - np.outer(K, H)
    P = IKH @ s.P @ IKH.T + sigma * sigma * np.outer(K, K)
    return EkfState(x, 0.5 * (P + P.T))


def _held_states(p: EstimatorParams):
    """The slice of the states beyond the angles and rates (gyro bias and
    self-calibration), which ``hold`` keeps from updating."""
    _, n = state_layout(p)
    return slice(4, n) if n > 4 else None


def misalign_held(p: EstimatorParams, noise) -> bool:
    """Whether the misalignment states are held at the calibration's values
    (not estimated in flight): the standstill calibration measured the
    gyros or the accelerometers (``noise`` = (gyro, accel) per sample)
    noisier than ``p.misalign_max_noise`` times the tuned noise."""
    gyro, accel = noise
    k = p.misalign_max_noise
    return bool(gyro > k * p.tuned_gyro_noise or accel > k * p.tuned_accel_noise)


def correct_sample(sample, x, p: EstimatorParams) -> np.ndarray:
    """``sample`` with each accelerometer turned back by the state's
    misalignment estimate (unchanged without misalignment states)."""
    sl = state_layout(p)[0].get("misalign")
    if sl is None:
        return np.asarray(sample, dtype=float)
    return ImuCalibration(misalign=tuple(float(e) for e in np.asarray(x)[sl])).correct(sample)


def split_sample(sample):
    """IMU 6-vector -> (z = gyro1, gyro2, mu_y1, mu_y2; u = mu_x1, mu_x2)."""
    g1, g2, a1x, a1y, a2x, a2y = sample
    return np.array([g1, g2, a1y, a2y]), np.array([a1x, a2x])


def ekf_step(s: EkfState, u_prev, sample, p: EstimatorParams, *, first: bool = False,
             hold: bool = False, hold_misalign: bool = False):
    """One filter period: predict with the previous input, update with the
    new sample.  ``u_prev`` holds the previous corrected accelerometer
    readings (mu_x1, mu_x2, mu_y1, mu_y2; the first two suffice without
    misalignment states).  ``hold``: see :func:`ekf_update`.  Returns (new
    state, this sample's 4 readings)."""
    z, u = split_sample(correct_sample(sample, s.x, p))
    acc = np.concatenate((u, z[2:4]))
    if not first:
        u_prev = np.asarray(u_prev, dtype=float)
        radial = prediction_input(u_prev[2:4], z[2:4], p) if len(u_prev) > 2 else None
        s = ekf_predict(s, prediction_input(u_prev[:2], u, p), p, radial=radial)
    return ekf_update(s, z, u, p, hold=hold, hold_misalign=hold_misalign), acc


def prediction_input(u_prev, u, p: EstimatorParams) -> np.ndarray:
    """The accelerations a prediction over one period uses: (5.3), explicit
    Euler with the previous ones; ``"trapezoid"`` averages both ends of the
    period (and steps the angles to second order); ``"heun"`` takes both
    ends (stacked: :func:`input_ends`)."""
    if p.integration == "euler":
        return np.asarray(u_prev)
    if p.integration == "heun":
        return np.concatenate((u_prev, u))
    return 0.5 * (np.asarray(u_prev) + u)


# ----------------------------------------------------------- Drake system

class KinematicEkf(LeafSystem):
    """Discrete EKF at ``params.period`` on the tick schedule
    (:mod:`bplir_drake.systems.schedule`).

    Input ``imu`` (6, see :data:`bplir_drake.systems.imu.IMU_COLUMNS`) and,
    with ``line = (l1, l2, alpha, sigma)`` (nominal link lengths, the line's
    incline, the reading's noise), ``line_gap`` (2: a line range sensor's
    reading and valid flag, :class:`~bplir_drake.systems.line_sensor.LineSensor`),
    fused after the IMU sample (:func:`ekf_gap_update`).
    Outputs ``estimate`` (theta1, theta2, omega1, omega2: absolute),
    ``estimate_relative`` (q1, q2, q1d, q2d), ``covariance_diagonal`` (n) and
    ``gyro_bias`` (2): the posterior of the sample held at the input,
    computed (once per tick) from the stored posterior of the previous tick,
    which is stored at the next tick.
    """

    def __init__(self, params: EstimatorParams, x0=(0.0, 0.0, 0.0, 0.0), sigmas=None,
                 calibration: ImuCalibration | None = None, line=None):
        super().__init__()
        if not isinstance(params, EstimatorParams):
            raise TypeError("KinematicEkf takes EstimatorParams (geometry and noise only)")
        self.params = params
        calibration = calibration or ImuCalibration()
        layout, _ = state_layout(params)
        if "bias" in layout:
            x0 = (*np.asarray(x0, dtype=float)[:4], *calibration.bias)
        init = initial_state(params, x0, sigmas)
        self._bias = layout.get("bias")
        self.n = n = len(init.x)
        self.imu_port = self.DeclareVectorInputPort("imu", 6)
        # a line range sensor's (reading, valid): ekf_gap_update with line
        self._line = tuple(float(v) for v in line) if line is not None else None
        self.line_port = (self.DeclareVectorInputPort("line_gap", 2)
                          if line is not None else None)
        # [x (n), P (n*n), previous corrected accelerometer readings (4),
        # first-sample flag]: _unpack()
        packed = np.concatenate([init.x, init.P.ravel(), np.zeros(4), [1.0]])
        self._state = self.DeclareDiscreteState(packed)
        # the standstill calibration: samples are corrected before the update,
        # and the filter's R widened to the noise it measured
        self._calibration = self.DeclareAbstractParameter(AbstractValue.Make(calibration))
        self._tuned = self.DeclareAbstractParameter(AbstractValue.Make(
            params.with_measured_noise(*calibration.noise)))
        self._post = declare_tick_result(self, self._posterior,
                                         {self.xd_ticket(), self.all_input_ports_ticket()})
        declare_store(self, params.period, self._store)
        dep = {self._post.ticket()}
        self.estimate_port = self.DeclareVectorOutputPort("estimate", 4, self._out_abs, dep)
        self.relative_port = self.DeclareVectorOutputPort("estimate_relative", 4, self._out_rel,
                                                          dep)
        self.covariance_port = self.DeclareVectorOutputPort("covariance_diagonal", n,
                                                            self._out_cov, dep)
        self.bias_port = self.DeclareVectorOutputPort("gyro_bias", 2, self._out_bias, dep)

    @staticmethod
    def _pack(s: EkfState, u, first: bool) -> np.ndarray:
        """The packed discrete state of :meth:`_unpack`'s parts."""
        return np.concatenate([s.x, s.P.ravel(), u, [1.0 if first else 0.0]])

    def _unpack(self, v):
        """(filter state, previous accelerometer input, first-sample flag) of
        the packed discrete state."""
        n = self.n
        return (EkfState(v[:n].copy(), v[n:n + n * n].reshape(n, n).copy()),
                v[n + n * n:n + n * n + 4], v[-1] > 0.5)

    def _posterior(self, context):
        """The packed filter state after this tick's sample."""
        s, u_prev, first = self._unpack(context.get_discrete_state(self._state).get_value())
        calibration = context.get_abstract_parameter(self._calibration).get_value()
        sample = calibration.correct(self.imu_port.Eval(context))
        tuned = context.get_abstract_parameter(self._tuned).get_value()
        s, u = ekf_step(s, u_prev, sample, tuned, first=first,
                        hold=context.get_time() < self.params.calibrate_after,
                        hold_misalign=misalign_held(self.params, calibration.noise))
        if self._line is not None:
            reading, valid = self.line_port.Eval(context)
            if valid > 0.5:
                s = ekf_gap_update(s, reading - calibration.line_offset, self._line)
        return self._pack(s, u, False)

    def _store(self, context, discrete_state):
        discrete_state.get_mutable_vector(self._state).SetFromVector(self._post.Eval(context))

    def set_calibration(self, context, calibration: ImuCalibration) -> None:
        """Use ``calibration`` in ``context`` (root, before the run): its
        corrections on every sample, its gyro biases as the initial bias
        estimate and its measured noise in R
        (:meth:`~bplir_drake.params.EstimatorParams.with_measured_noise`)."""
        own = self.GetMyMutableContextFromRoot(context)
        own.get_mutable_abstract_parameter(self._calibration).set_value(calibration)
        own.get_mutable_abstract_parameter(self._tuned).set_value(
            self.params.with_measured_noise(*calibration.noise))
        state = own.get_mutable_discrete_state(self._state)
        if self._bias is not None:
            state.SetAtIndex(self._bias.start, calibration.bias[0])
            state.SetAtIndex(self._bias.start + 1, calibration.bias[1])
        sl = state_layout(self.params)[0].get("misalign")
        if sl is not None and misalign_held(self.params, calibration.noise):
            # held at the calibration's values, taken as exact: the filter of
            # the angles is then the one without misalignment states
            s, u, first = self._unpack(state.get_value())
            s.P[sl, :] = 0.0
            s.P[:, sl] = 0.0
            state.SetFromVector(self._pack(s, u, first))

    def _out_abs(self, context, out):
        out.SetFromVector(self._post.Eval(context)[:4])

    def _out_rel(self, context, out):
        x = self._post.Eval(context)
        out.SetFromVector([x[0], x[1] - x[0], x[2], x[3] - x[2]])

    def _out_cov(self, context, out):
        n = self.n
        out.SetFromVector(self._post.Eval(context)[n:n + n * n:n + 1])

    def _out_bias(self, context, out):
        x = self._post.Eval(context)
        out.SetFromVector(x[self._bias] if self._bias is not None else [0.0, 0.0])
