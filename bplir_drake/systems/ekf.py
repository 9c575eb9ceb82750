"""Kinematic extended Kalman filter (chapter 5) as a discrete Drake system.

State ``(theta1, theta2, omega1, omega2[, b1, b2])`` in absolute angles, with
optional gyro-bias states (the dissertation's recommended extension).
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
from functools import lru_cache

import numpy as np
import pydrake.math as dmath
from pydrake.autodiffutils import AutoDiffXd, ExtractGradient, ExtractValue, InitializeAutoDiff
from pydrake.common.value import AbstractValue
from pydrake.systems.framework import LeafSystem

from ..params import EstimatorParams
from .calibration import ImuCalibration
from .schedule import declare_store, declare_tick_result


# ----------------------------------------------------------- model functions

def kinematic_f(x, u, p: EstimatorParams):
    """Continuous kinematic model (5.10); ``x`` may carry bias states."""
    t1, t2, w1, w2 = x[0], x[1], x[2], x[3]
    s1, s2 = dmath.sin(t1), dmath.sin(t2)
    s21, c21 = dmath.sin(t2 - t1), dmath.cos(t2 - t1)
    a1 = (u[0] - p.g * s1) / p.r1
    a2 = (-p.l1 * c21 * a1 + u[1] - p.g * s2 - p.l1 * w1 ** 2 * s21) / p.r2
    out = [w1, w2, a1, a2]
    out += [0.0 * x[i] for i in range(4, len(x))]  # biases: random walk
    return np.array(out)


def kinematic_h(x, u, p: EstimatorParams):
    """Measurement model: gyro rates (+ bias) and the radial specific forces."""
    t1, t2, w1, w2 = x[0], x[1], x[2], x[3]
    c1, c2 = dmath.cos(t1), dmath.cos(t2)
    s21, c21 = dmath.sin(t2 - t1), dmath.cos(t2 - t1)
    a1 = (u[0] - p.g * dmath.sin(t1)) / p.r1
    b1 = x[4] if len(x) > 4 else 0.0
    b2 = x[5] if len(x) > 4 else 0.0
    return np.array([
        w1 + b1,
        w2 + b2,
        p.r1 * w1 ** 2 + p.g * c1,
        p.l1 * (-a1 * s21 + w1 ** 2 * c21) + p.r2 * w2 ** 2 + p.g * c2,
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


@lru_cache(maxsize=64)
def noise_matrices(p: EstimatorParams):
    """(Q_u (2x2) on the accelerometer inputs, R (4x4), Q_bias per second);
    cached per parameter block (read-only arrays)."""
    Qu = p.accel_process_sigma ** 2 * np.eye(2)
    R = np.diag([p.gyro_meas_sigma ** 2] * 2 + [p.accel_meas_sigma ** 2] * 2)
    Qu.flags.writeable = R.flags.writeable = False
    return Qu, R, p.bias_walk ** 2


def initial_state(p: EstimatorParams, x0, sigmas=None) -> EkfState:
    """Initial filter state; ``sigmas`` = (angle, rate[, bias]) overrides p0."""
    n = 6 if p.estimate_bias else 4
    x = np.zeros(n)
    x[:4] = np.asarray(x0, dtype=float)[:4]
    if p.estimate_bias and len(x0) >= 6:
        x[4:6] = x0[4:6]
    a, r, b = (tuple(sigmas) + (p.bias_sigma0,))[:3] if sigmas is not None else \
        (p.p0_angle, p.p0_rate, p.bias_sigma0)
    sd = [a] * 2 + [r] * 2 + ([b] * 2 if p.estimate_bias else [])
    return EkfState(x, np.diag(np.square(sd)))


def discrete_f(x, u, p: EstimatorParams):
    """One period of (5.10): explicit Euler (5.3), or with ``integration =
    "trapezoid"`` a second-order step for the angles
    ``theta + T omega + T^2/2 omega'`` (the Euler angle update is the
    rectangle rule, which drifts during the fast elbow motion of a swing)."""
    Ts = p.period
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
    a1 = (u[0] - p.g * s1) / p.r1
    a1_t1 = -p.g * c1 / p.r1
    l1, r2 = p.l1, p.r2
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
    B[2, 0] = 1.0 / p.r1
    B[3, 0] = -l1 * c21 / (p.r1 * r2)
    B[3, 1] = 1.0 / r2
    return f, A, B


def discrete_f_jacobians(x, u, p: EstimatorParams):
    """(x_next, A = df_d/dx, W = df_d/du) of :func:`discrete_f` in closed form."""
    Ts = p.period
    f, Jx, Ju = kinematic_f_jacobians(x, u, p)
    x_new = x + Ts * f
    A = np.eye(len(x)) + Ts * Jx
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
    a1 = (u[0] - p.g * s1) / p.r1
    a1_t1 = -p.g * c1 / p.r1
    l1 = p.l1
    b1, b2 = (x[4], x[5]) if n > 4 else (0.0, 0.0)
    h = np.array([w1 + b1, w2 + b2, p.r1 * w1 * w1 + p.g * c1,
                  l1 * (-a1 * s21 + w1 * w1 * c21) + p.r2 * w2 * w2 + p.g * c2])
    H = np.zeros((4, n))
    H[0, 2] = H[1, 3] = 1.0
    if n > 4:
        H[0, 4] = H[1, 5] = 1.0
    H[2, 0] = -p.g * s1
    H[2, 2] = 2.0 * p.r1 * w1
    H[3, 0] = l1 * (-a1_t1 * s21 + a1 * c21 + w1 * w1 * s21)
    H[3, 1] = l1 * (-a1 * c21 - w1 * w1 * s21) - p.g * s2
    H[3, 2] = 2.0 * l1 * w1 * c21
    H[3, 3] = 2.0 * p.r2 * w2
    return h, H


def ekf_predict(s: EkfState, u, p: EstimatorParams, *, with_jacobian: bool = False):
    """(5.23)-(5.24): prediction over one period; ``A = df_d/dx`` and
    ``W = df_d/du`` in closed form (:func:`discrete_f_jacobians`).  With
    ``with_jacobian`` returns ``(state, A)`` (for a smoother)."""
    x_new, A, W = discrete_f_jacobians(s.x, np.asarray(u, dtype=float), p)
    n = len(s.x)
    Qu, _, qb = noise_matrices(p)
    P = A @ s.P @ A.T + (W @ Qu) @ W.T
    if n > 4:
        P[4:, 4:] += qb * p.period * np.eye(2)
    return (EkfState(x_new, P), A) if with_jacobian else EkfState(x_new, P)


def ekf_update(s: EkfState, z, u, p: EstimatorParams, *, with_innovation: bool = False):
    """(5.29)-(5.31), Joseph form.  With ``with_innovation`` returns
    ``(state, innovation, its covariance S)`` (for consistency checks)."""
    h, H = kinematic_h_jacobian(s.x, np.asarray(u, dtype=float), p)
    _, R, _ = noise_matrices(p)
    PHt = s.P @ H.T
    S = H @ PHt + R
    K = np.linalg.solve(S, PHt.T).T
    nu = np.asarray(z, dtype=float) - h
    x = s.x + K @ nu
    IKH = np.eye(len(s.x)) - K @ H
    P = IKH @ s.P @ IKH.T + K @ R @ K.T
    out = EkfState(x, 0.5 * (P + P.T))
    return (out, nu, S) if with_innovation else out


def split_sample(sample):
    """IMU 6-vector -> (z = gyro1, gyro2, mu_y1, mu_y2; u = mu_x1, mu_x2)."""
    g1, g2, a1x, a1y, a2x, a2y = sample
    return np.array([g1, g2, a1y, a2y]), np.array([a1x, a2x])


def ekf_step(s: EkfState, u_prev, sample, p: EstimatorParams, *, first: bool = False):
    """One filter period: predict with the previous input, update with the
    new sample.  Returns (new state, new input)."""
    z, u = split_sample(sample)
    if not first:
        s = ekf_predict(s, prediction_input(u_prev, u, p), p)
    return ekf_update(s, z, u, p), u


def prediction_input(u_prev, u, p: EstimatorParams) -> np.ndarray:
    """The accelerations a prediction over one period uses: (5.3), explicit
    Euler with the previous ones; ``"trapezoid"`` averages both ends of the
    period (and steps the angles to second order)."""
    return np.asarray(u_prev) if p.integration == "euler" else 0.5 * (np.asarray(u_prev) + u)


# ----------------------------------------------------------- Drake system

class KinematicEkf(LeafSystem):
    """Discrete EKF at ``params.period`` on the tick schedule
    (:mod:`bplir_drake.systems.schedule`).

    Input ``imu`` (6, see :data:`bplir_drake.systems.imu.IMU_COLUMNS`).
    Outputs ``estimate`` (theta1, theta2, omega1, omega2: absolute),
    ``estimate_relative`` (q1, q2, q1d, q2d), ``covariance_diagonal`` (n) and
    ``gyro_bias`` (2): the posterior of the sample held at the input,
    computed (once per tick) from the stored posterior of the previous tick,
    which is stored at the next tick.
    """

    def __init__(self, params: EstimatorParams, x0=(0.0, 0.0, 0.0, 0.0), sigmas=None,
                 calibration: ImuCalibration | None = None):
        super().__init__()
        if not isinstance(params, EstimatorParams):
            raise TypeError("KinematicEkf takes EstimatorParams (geometry and noise only)")
        self.params = params
        calibration = calibration or ImuCalibration()
        if params.estimate_bias:
            x0 = (*np.asarray(x0, dtype=float)[:4], *calibration.bias)
        init = initial_state(params, x0, sigmas)
        self.n = n = len(init.x)
        self.imu_port = self.DeclareVectorInputPort("imu", 6)
        # [x (n), P (n*n), previous accelerometer input (2), first-sample flag]: _unpack()
        packed = np.concatenate([init.x, init.P.ravel(), [0.0, 0.0], [1.0]])
        self._state = self.DeclareDiscreteState(packed)
        # the standstill calibration: samples are corrected before the update
        self._calibration = self.DeclareAbstractParameter(AbstractValue.Make(calibration))
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

    def _unpack(self, v):
        """(filter state, previous accelerometer input, first-sample flag) of
        the packed discrete state."""
        n = self.n
        return (EkfState(v[:n].copy(), v[n:n + n * n].reshape(n, n).copy()),
                v[n + n * n:n + n * n + 2], v[-1] > 0.5)

    def _posterior(self, context):
        """The packed filter state after this tick's sample."""
        s, u_prev, first = self._unpack(context.get_discrete_state(self._state).get_value())
        sample = context.get_abstract_parameter(self._calibration).get_value().correct(
            self.imu_port.Eval(context))
        s, u = ekf_step(s, u_prev, sample, self.params, first=first)
        return np.concatenate([s.x, s.P.ravel(), u, [0.0]])

    def _store(self, context, discrete_state):
        discrete_state.get_mutable_vector(self._state).SetFromVector(self._post.Eval(context))

    def set_calibration(self, context, calibration: ImuCalibration) -> None:
        """Use ``calibration`` in ``context`` (root, before the run): its
        corrections on every sample and its gyro biases as the initial bias
        estimate."""
        own = self.GetMyMutableContextFromRoot(context)
        own.get_mutable_abstract_parameter(self._calibration).set_value(calibration)
        if self.n > 4:
            state = own.get_mutable_discrete_state(self._state)
            state.SetAtIndex(4, calibration.bias[0])
            state.SetAtIndex(5, calibration.bias[1])

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
        out.SetFromVector(x[4:6] if self.n > 4 else [0.0, 0.0])
