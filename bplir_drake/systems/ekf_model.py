"""The kinematic model the EKF filters with: its state layout, the continuous and discrete process and measurement models with their Jacobians, and their noise."""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache, wraps
import numpy as np
import pydrake.math as dmath
from pydrake.autodiffutils import AutoDiffXd, ExtractGradient, ExtractValue, InitializeAutoDiff
from ..params import EstimatorParams


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


def _link_terms(x, u, p: EstimatorParams):
    """The sines and cosines of both angles and of their difference, the IMU
    radii, link 1's angular acceleration from IMU 1 and its derivative in
    theta1 -- shared by the closed-form Jacobians."""
    t1, t2 = float(x[0]), float(x[1])
    s1, c1, s2, c2 = math.sin(t1), math.cos(t1), math.sin(t2), math.cos(t2)
    r1, r2 = (float(r) for r in imu_radii(x, p))
    return (s1, c1, s2, c2, math.sin(t2 - t1), math.cos(t2 - t1), r1, r2,
            (u[0] - p.g * s1) / r1, -p.g * c1 / r1)


def kinematic_f_jacobians(x, u, p: EstimatorParams):
    """(f, df/dx, df/du) of :func:`kinematic_f` in closed form (plain floats;
    tested against AutoDiff)."""
    n = len(x)
    t1, t2, w1 = float(x[0]), float(x[1]), float(x[2])
    s1, c1, s2, c2, s21, c21, r1, r2, a1, a1_t1 = _link_terms(x, u, p)
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
    s1, c1, s2, c2, s21, c21, r1, r2, a1, a1_t1 = _link_terms(x, u, p)
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
