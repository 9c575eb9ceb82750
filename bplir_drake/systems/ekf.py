"""Kinematic extended Kalman filter (chapter 5) as a discrete Drake system.

State ``(theta1, theta2, omega1, omega2[, b1, b2][, eps1, eps2][, k1, k2])``
in absolute angles, with optional gyro-bias states (the dissertation's
recommended extension) and self-calibration states: each
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

import numpy as np
import pydrake.math as dmath
from pydrake.common.value import AbstractValue

from .pysystem import PySystem
from ..params import EstimatorParams
from . import ekf_kernel
from .standstill import ImuCalibration
from .line_sensor import line_gap
from .schedule import declare_store, declare_tick_result
from .ekf_model import (
    _identity, state_layout, imu_radii, EkfState, noise_matrices, _input_noises, initial_state, discrete_f_jacobians, kinematic_h_jacobian, _walk_variances, misalignment_columns)


# ----------------------------------------------------------- model functions


# ----------------------------------------------------------- the filter step


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
    if p.inflate_nis != "never":   # covariance inflation (params doc)
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
    noisier than ``p.misalign_max_noise`` times the noise the filter assumes."""
    gyro, accel = noise
    k = p.misalign_max_noise
    return bool(gyro > k * p.gyro_meas_sigma or accel > k * p.tuned_accel_noise)


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

class KinematicEkf(PySystem):
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
        # the discrete state, one named group each: the filter's state x (n),
        # its covariance P (n x n, row by row), the previous corrected
        # accelerometer readings (4) and the first-sample flag
        self._x = self.DeclareDiscreteState(init.x)
        self._P = self.DeclareDiscreteState(init.P.ravel())
        self._u = self.DeclareDiscreteState(np.zeros(4))
        self._first = self.DeclareDiscreteState([1.0])
        # the standstill calibration: samples are corrected before the update,
        # and the filter's R widened to the noise it measured
        #: the built calibration parameter (:meth:`_compiled`; a context's default)
        self.compiled_calibration = self._compiled(calibration)
        self._calibration = self.DeclareAbstractParameter(AbstractValue.Make(
            self.compiled_calibration))
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

    def _compiled(self, calibration: ImuCalibration):
        """(calibration, the packed constants of the filter tuned to its
        measured noise, their random walks, its corrections, whether the
        misalignment states are held) for the compiled step."""
        consts, walk = ekf_kernel.pack(self.params.with_measured_noise(*calibration.noise))
        cal = np.array([*calibration.misalign, *calibration.scale], dtype=float)
        return calibration, consts, walk, cal, misalign_held(self.params, calibration.noise)

    def filter_state(self, context):
        """The stored discrete state, by name: (filter state ``EkfState(x, P)``,
        previous accelerometer input, first-sample flag) in ``context`` (this
        system's)."""
        n = self.n
        state = context.get_discrete_state()
        return (EkfState(state.get_vector(self._x).CopyToVector(),
                         state.get_vector(self._P).CopyToVector().reshape(n, n)),
                state.get_vector(self._u).CopyToVector(),
                state.get_vector(self._first).GetAtIndex(0) > 0.5)

    def _posterior(self, context):
        """(filter state, accelerometer input) after this tick's sample."""
        state = context.get_discrete_state()
        return self.posterior(
            state.get_vector(self._x).get_value(),
            state.get_vector(self._P).get_value(), state.get_vector(self._u).get_value(),
            state.get_vector(self._first).GetAtIndex(0) > 0.5, self.imu_port.Eval(context),
            context.get_time(), context.get_abstract_parameter(self._calibration).get_value(),
            self.line_port.Eval(context) if self._line is not None else None)

    def posterior(self, x, P, u, first: bool, imu, t: float, compiled, line_gap=None):
        """(filter state, accelerometer input) after the sample ``imu`` from
        the stored ``x``, ``P`` (flat), ``u`` and first-sample flag at time
        ``t``, with the calibration parameter ``compiled`` (:meth:`_compiled`)
        and the line sensor's ``line_gap`` (reading, valid): the compiled step
        (:func:`~bplir_drake.systems.ekf_kernel.step`, the same arithmetic as
        :func:`ekf_step`)."""
        n = self.n
        calibration, consts, walk, cal, held = compiled
        x, P, u = ekf_kernel.step(x, P.reshape(n, n), u, imu, first,
                                  t < self.params.calibrate_after, held, consts, walk, cal)
        s = EkfState(x, P)
        if line_gap is not None:
            reading, valid = line_gap
            if valid > 0.5:
                s = ekf_gap_update(s, reading - calibration.line_offset, self._line)
        return s, u

    def _store(self, context, discrete_state):
        s, u = self._post.Eval(context)
        discrete_state.get_mutable_vector(self._x).SetFromVector(s.x)
        discrete_state.get_mutable_vector(self._P).SetFromVector(s.P.ravel())
        discrete_state.get_mutable_vector(self._u).SetFromVector(u)
        discrete_state.get_mutable_vector(self._first).SetAtIndex(0, 0.0)

    def set_calibration(self, context, calibration: ImuCalibration) -> None:
        """Use ``calibration`` in ``context`` (root, before the run): its
        corrections on every sample, its gyro biases as the initial bias
        estimate and its measured noise in R
        (:meth:`~bplir_drake.params.EstimatorParams.with_measured_noise`)."""
        own = self.GetMyMutableContextFromRoot(context)
        own.get_mutable_abstract_parameter(self._calibration).set_value(
            self._compiled(calibration))
        x = own.get_mutable_discrete_state(self._x)
        P = own.get_mutable_discrete_state(self._P)
        new_x, new_P = self.calibrated_start(x.CopyToVector(), P.CopyToVector(), calibration)
        x.SetFromVector(new_x)
        P.SetFromVector(new_P)

    def calibrated_start(self, x, P, calibration: ImuCalibration):
        """The stored ``x`` and flat ``P`` started from ``calibration``: its
        gyro biases as the bias estimate, and misalignment states it holds
        taken as exact (their rows and columns of P zeroed: the filter of
        the angles is then the one without misalignment states)."""
        x, P = np.array(x, dtype=float), np.array(P, dtype=float)
        if self._bias is not None:
            x[self._bias.start:self._bias.start + 2] = calibration.bias[:2]
        sl = state_layout(self.params)[0].get("misalign")
        if sl is not None and misalign_held(self.params, calibration.noise):
            cov = P.reshape(self.n, self.n)
            cov[sl, :] = 0.0
            cov[:, sl] = 0.0
        return x, P

    def _out_abs(self, context, out):
        out.SetFromVector(self._post.Eval(context)[0].x[:4])

    def _out_rel(self, context, out):
        x = self._post.Eval(context)[0].x   # theta1, theta2, omega1, omega2 (AbsoluteState)
        out.SetFromVector((x[0], x[1] - x[0], x[2], x[3] - x[2]))

    def _out_cov(self, context, out):
        out.SetFromVector(np.diag(self._post.Eval(context)[0].P))

    def _out_bias(self, context, out):
        x = self._post.Eval(context)[0].x
        out.SetFromVector(x[self._bias] if self._bias is not None else [0.0, 0.0])
