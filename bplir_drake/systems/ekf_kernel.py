"""The EKF's tick compiled: one numba function for the in-loop filter step.

:func:`~bplir_drake.systems.ekf.ekf_step` is the filter written for
reading: it builds small numpy arrays for the Jacobians and products,
which costs far more than the arithmetic at 100 Hz.  :func:`step` is the
same step (prediction with the previous tick's readings, update with this
tick's sample, misalignment correction, covariance inflation, Schmidt
holds; Joseph form) on plain arrays in one compiled call; the constants of
a parameter block are packed once by :func:`pack`.  Tested against
:func:`~bplir_drake.systems.ekf.ekf_step` to rounding over a swing's samples
for every state layout and integration.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from ..params import EstimatorParams
from ..params.blocks import number_or
from .ekf_model import _walk_variances, state_layout

#: the integrations by code in the packed constants
INTEGRATIONS = {"euler": 0, "trapezoid": 1, "heun": 2}
# indices of the packed constants
_R1, _R2, _L1, _G, _TS, _INT, _NIS, _BIAS, _MIS, _SCALE, _POS, _QU = range(12)
_RDIAG = 12   # 4 measurement variances follow


def pack(p: EstimatorParams) -> tuple[np.ndarray, np.ndarray]:
    """(constants, random-walk variances per second) of ``p`` for :func:`step`:
    geometry, period, integration, inflation threshold, where each optional
    state group starts (-1: absent), the input and measurement noise."""
    layout, _ = state_layout(p)

    def start(group):
        return float(layout[group].start) if group in layout else -1.0

    c = np.array([p.r1, p.r2, p.l1, p.g, p.period, INTEGRATIONS[p.integration], number_or(p.inflate_nis),
                  start("bias"), start("misalign"), start("scale"), start("position"),
                  p.accel_process_sigma ** 2, p.gyro_meas_sigma ** 2, p.gyro_meas_sigma ** 2,
                  p.accel_meas_sigma ** 2, p.accel_meas_sigma ** 2])
    return c, np.array(_walk_variances(p), dtype=float)


@njit(cache=True)
def _radii(x, c):
    pos = int(c[_POS])
    if pos >= 0:
        return x[pos], x[pos + 1]
    return c[_R1], c[_R2]


@njit(cache=True)
def _link_terms(x, u0, c):
    """What the process and measurement models share at ``x``: (g, l1, the
    sines and cosines of theta1, theta2 and theta2 - theta1, the IMU radii,
    ``a1 = (u0 - g sin theta1) / r1`` of (5.10) and its derivative in
    theta1)."""
    t1, t2 = x[0], x[1]
    g, l1 = c[_G], c[_L1]
    s1, c1, s2, c2 = math.sin(t1), math.cos(t1), math.sin(t2), math.cos(t2)
    s21, c21 = math.sin(t2 - t1), math.cos(t2 - t1)
    r1, r2 = _radii(x, c)
    a1 = (u0 - g * s1) / r1
    a1_t1 = -g * c1 / r1
    return g, l1, s1, c1, s2, c2, s21, c21, r1, r2, a1, a1_t1


@njit(cache=True)
def _f_jacobians(x, u0, u1, c):
    """(f, df/dx, df/du) of the continuous kinematic model (5.10)."""
    n = x.shape[0]
    w1 = x[2]
    g, l1, s1, c1, s2, c2, s21, c21, r1, r2, a1, a1_t1 = _link_terms(x, u0, c)
    a2 = (-l1 * c21 * a1 + u1 - g * s2 - l1 * w1 * w1 * s21) / r2
    f = np.zeros(n)
    f[0], f[1], f[2], f[3] = w1, x[3], a1, a2
    A = np.zeros((n, n))
    A[0, 2] = 1.0
    A[1, 3] = 1.0
    A[2, 0] = a1_t1
    A[3, 0] = (-l1 * s21 * a1 - l1 * c21 * a1_t1 + l1 * w1 * w1 * c21) / r2
    A[3, 1] = (l1 * s21 * a1 - g * c2 - l1 * w1 * w1 * c21) / r2
    A[3, 2] = -2.0 * l1 * w1 * s21 / r2
    B = np.zeros((n, 2))
    B[2, 0] = 1.0 / r1
    B[3, 0] = -l1 * c21 / (r1 * r2)
    B[3, 1] = 1.0 / r2
    pos = int(c[_POS])
    if pos >= 0:
        A[2, pos] = -a1 / r1
        A[3, pos] = l1 * c21 * a1 / (r1 * r2)
        A[3, pos + 1] = -a2 / r2
    return f, A, B


@njit(cache=True)
def _mm(A, B):
    """A B by loops (small matrices: no BLAS call, no temporaries)."""
    n, k, m = A.shape[0], A.shape[1], B.shape[1]
    out = np.zeros((n, m))
    for i in range(n):
        for j in range(m):
            acc = 0.0
            for r in range(k):
                acc += A[i, r] * B[r, j]
            out[i, j] = acc
    return out


@njit(cache=True)
def _scaled(s, X):
    """s X (2-d), by loops."""
    out = np.empty(X.shape)
    for i in range(X.shape[0]):
        for j in range(X.shape[1]):
            out[i, j] = s * X[i, j]
    return out


@njit(cache=True)
def _scaled_sum(s, X, t, Y):
    """s (X + t Y) (2-d), by loops."""
    out = np.empty(X.shape)
    for i in range(X.shape[0]):
        for j in range(X.shape[1]):
            out[i, j] = s * (X[i, j] + t * Y[i, j])
    return out


@njit(cache=True)
def _transposed(X):
    """X^T as a new C-ordered array."""
    out = np.empty((X.shape[1], X.shape[0]))
    for i in range(X.shape[0]):
        for j in range(X.shape[1]):
            out[j, i] = X[i, j]
    return out


@njit(cache=True)
def _mmt(A, B):
    """A B^T: :func:`_mm` of the transpose (the same products, summed in
    the same order)."""
    return _mm(A, _transposed(B))


@njit(cache=True)
def _predict(x, P, u, radial, c, walk):
    """(x, P) after one period with the inputs ``u`` (2, or 4 for both
    ends with Heun's step) and the corrected radial readings ``radial``
    paired with them."""
    n = x.shape[0]
    Ts = c[_TS]
    mode = int(c[_INT])
    x_new = np.empty(n)
    if mode == 2:
        both = u.shape[0] == 4
        f1, J1, B1 = _f_jacobians(x, u[0], u[1], c)
        for i in range(n):
            x_new[i] = x[i] + Ts * f1[i]
        f2, J2, B2 = _f_jacobians(x_new, u[2 if both else 0], u[3 if both else 1], c)
        step = _scaled(Ts, J1)
        for i in range(n):
            step[i, i] += 1.0
        A = _scaled_sum(0.5 * Ts, J1, 1.0, _mm(J2, step))
        for i in range(n):
            A[i, i] += 1.0
        W0 = _scaled_sum(0.5 * Ts, B1, Ts, _mm(J2, B1))
        W1 = _scaled(0.5 * Ts, B2)
        W = np.empty((n, 4 if both else 2))
        for i in range(n):
            for j in range(2):
                if both:
                    W[i, j], W[i, 2 + j] = W0[i, j], W1[i, j]
                else:
                    W[i, j] = W0[i, j] + W1[i, j]
        for i in range(n):
            x_new[i] = x[i] + 0.5 * Ts * (f1[i] + f2[i])
    else:
        f, Jx, Ju = _f_jacobians(x, u[0], u[1], c)
        for i in range(n):
            x_new[i] = x[i] + Ts * f[i]
        A = _scaled(Ts, Jx)
        for i in range(n):
            A[i, i] += 1.0
        W = _scaled(Ts, Ju)
        if mode == 1:
            h = 0.5 * Ts * Ts
            for i in range(2):
                x_new[i] += h * f[2 + i]
                for j in range(n):
                    A[i, j] += h * Jx[2 + i, j]
                for j in range(2):
                    W[i, j] += h * Ju[2 + i, j]
    mis = int(c[_MIS])
    if mis >= 0 and radial.shape[0] > 0:
        for i in range(n):
            for j in range(2):
                A[i, mis + j] -= W[i, j] * radial[j]
                if W.shape[1] == 4:
                    A[i, mis + j] -= W[i, j + 2] * radial[j + 2]
    P_new = _mmt(_mm(A, P), A)
    WW = _mmt(W, W)
    for i in range(n):
        for j in range(n):
            P_new[i, j] += c[_QU] * WW[i, j]
        P_new[i, i] += walk[i] * Ts
    return x_new, P_new


@njit(cache=True)
def _h_jacobian(x, u0, c):
    """(h, dh/dx) of the measurement model."""
    n = x.shape[0]
    w1, w2 = x[2], x[3]
    g, l1, s1, c1, s2, c2, s21, c21, r1, r2, a1, a1_t1 = _link_terms(x, u0, c)
    b1 = b2 = k1 = k2 = 0.0
    bias, scale, pos = int(c[_BIAS]), int(c[_SCALE]), int(c[_POS])
    if bias >= 0:
        b1, b2 = x[bias], x[bias + 1]
    if scale >= 0:
        k1, k2 = x[scale], x[scale + 1]
    h = np.empty(4)
    h[0] = (1.0 + k1) * w1 + b1
    h[1] = (1.0 + k2) * w2 + b2
    h[2] = r1 * w1 * w1 + g * c1
    h[3] = l1 * (-a1 * s21 + w1 * w1 * c21) + r2 * w2 * w2 + g * c2
    H = np.zeros((4, n))
    H[0, 2], H[1, 3] = 1.0 + k1, 1.0 + k2
    if bias >= 0:
        H[0, bias] = 1.0
        H[1, bias + 1] = 1.0
    if scale >= 0:
        H[0, scale], H[1, scale + 1] = w1, w2
    H[2, 0] = -g * s1
    H[2, 2] = 2.0 * r1 * w1
    H[3, 0] = l1 * (-a1_t1 * s21 + a1 * c21 + w1 * w1 * s21)
    H[3, 1] = l1 * (-a1 * c21 - w1 * w1 * s21) - g * s2
    H[3, 2] = 2.0 * l1 * w1 * c21
    H[3, 3] = 2.0 * r2 * w2
    if pos >= 0:
        H[2, pos] = w1 * w1
        H[3, pos] = l1 * s21 * a1 / r1
        H[3, pos + 1] = w2 * w2
    return h, H, r1


@njit(cache=True)
def _cholesky_solve(S, B):
    """S^-1 B for the symmetric positive definite S (m x m) and B (m x k)."""
    m = S.shape[0]
    L = np.zeros((m, m))
    for i in range(m):
        for j in range(i + 1):
            acc = S[i, j]
            for r in range(j):
                acc -= L[i, r] * L[j, r]
            L[i, j] = math.sqrt(acc) if i == j else acc / L[j, j]
    out = B.copy()
    for col in range(B.shape[1]):
        for i in range(m):   # L y = b
            acc = out[i, col]
            for r in range(i):
                acc -= L[i, r] * out[r, col]
            out[i, col] = acc / L[i, i]
        for i in range(m - 1, -1, -1):   # L^T z = y
            acc = out[i, col]
            for r in range(i + 1, m):
                acc -= L[r, i] * out[r, col]
            out[i, col] = acc / L[i, i]
    return out


@njit(cache=True)
def _update(x, P, z, u, c, hold, hold_misalign):
    """(x, P) after the update with the readings ``z`` (gyro1, gyro2,
    mu_y1, mu_y2) and the tangential inputs ``u`` (Joseph form)."""
    n = x.shape[0]
    h, H, r1 = _h_jacobian(x, u[0], c)
    mis = int(c[_MIS])
    if mis >= 0:
        H[2, mis] -= u[0]
        H[3, mis + 1] -= u[1]
        H[3, mis] += c[_L1] * math.sin(x[1] - x[0]) / r1 * z[2]
    PHt = _mmt(P, H)
    S = _mm(H, PHt)
    for i in range(4):
        S[i, i] += c[_RDIAG + i]
    nu = np.empty((4, 1))
    for i in range(4):
        nu[i, 0] = z[i] - h[i]
    if c[_NIS] > 0.0:
        w = _cholesky_solve(S, nu)
        excess = (nu[0, 0] * w[0, 0] + nu[1, 0] * w[1, 0] + nu[2, 0] * w[2, 0]
                  + nu[3, 0] * w[3, 0]) / (c[_NIS] * 4)
        if excess > 1.0:
            P = _scaled(excess, P)
            PHt = _mmt(P, H)
            S = _mm(H, PHt)
            for i in range(4):
                S[i, i] += c[_RDIAG + i]
    K = _transposed(_cholesky_solve(S, _transposed(PHt)))   # P H^T S^-1 (S symmetric)
    if hold and n > 4:
        K[4:] = 0.0
    if hold_misalign and mis >= 0:
        K[mis:mis + 2] = 0.0
    Knu, KH = _mm(K, nu), _mm(K, H)
    x_new = np.empty(n)
    IKH = np.empty((n, n))
    for i in range(n):
        x_new[i] = x[i] + Knu[i, 0]
        for j in range(n):
            IKH[i, j] = -KH[i, j]
    for i in range(n):
        IKH[i, i] += 1.0
    P_new = _mmt(_mm(IKH, P), IKH)
    for i in range(n):
        for j in range(n):
            acc = 0.0
            for r in range(4):
                acc += K[i, r] * c[_RDIAG + r] * K[j, r]
            P_new[i, j] += acc
    out = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            out[i, j] = 0.5 * (P_new[i, j] + P_new[j, i])
    return x_new, out


@njit(cache=True)
def _turned(s, eps, scale):
    """The accelerometers of sample ``s`` turned back by ``eps`` (2) and
    divided by ``1 + scale`` (2), in place."""
    for i in range(2):
        ax, ay = s[2 + 2 * i], s[3 + 2 * i]
        ce, se = math.cos(eps[i]), math.sin(eps[i])
        k = 1.0 + scale[i]
        s[2 + 2 * i] = (ce * ax - se * ay) / k
        s[3 + 2 * i] = (se * ax + ce * ay) / k


@njit(cache=True)
def step(x, P, u_prev, sample, first, hold, hold_misalign, c, walk, cal):
    """One filter period on the raw sample (6): ``(x, P, this sample's
    corrected accelerometer readings mu_x1, mu_x2, mu_y1, mu_y2)``, as
    :func:`~bplir_drake.systems.ekf.ekf_step` on the sample corrected by
    the standstill calibration ``cal`` (misalignment 1, 2, scale 1, 2;
    :meth:`~bplir_drake.systems.standstill.ImuCalibration.correct`)."""
    s = sample.copy()
    if cal[0] != 0.0 or cal[1] != 0.0 or cal[2] != 0.0 or cal[3] != 0.0:
        _turned(s, cal[:2], cal[2:])
    mis = int(c[_MIS])
    if mis >= 0 and (x[mis] != 0.0 or x[mis + 1] != 0.0):   # by the state's estimate
        _turned(s, x[mis:mis + 2], np.zeros(2))
    z = np.array([s[0], s[1], s[3], s[5]])
    u = np.array([s[2], s[4]])
    acc = np.array([u[0], u[1], z[2], z[3]])
    if not first:
        mode = int(c[_INT])
        if mode == 2:
            uin = np.array([u_prev[0], u_prev[1], u[0], u[1]])
            radial = np.array([u_prev[2], u_prev[3], z[2], z[3]])
        elif mode == 1:
            uin = np.array([0.5 * (u_prev[0] + u[0]), 0.5 * (u_prev[1] + u[1])])
            radial = np.array([0.5 * (u_prev[2] + z[2]), 0.5 * (u_prev[3] + z[3])])
        else:
            uin = np.array([u_prev[0], u_prev[1]])
            radial = np.array([u_prev[2], u_prev[3]])
        x, P = _predict(x, P, uin, radial, c, walk)
    x, P = _update(x, P, z, u, c, hold, hold_misalign)
    return x, P, acc
