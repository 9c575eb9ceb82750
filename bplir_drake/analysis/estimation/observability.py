"""Observability of the linearised kinematic model along a trajectory (5.13).

At every sample of a trajectory the kinematic model (5.10) and the output map
(5.11) are linearised (AutoDiffXd: ``A = df/dx``, ``C = dh/dx``) and the
observability matrix ``O = [C; CA; CA^2; CA^3]`` is formed for the gyro-only
outputs (5.16) and for the full output map (5.18).  States are scaled by
``diag(angle_scale, angle_scale, rate_scale, rate_scale)`` (1 rad, 3 rad/s
by default) and the rows of O are normalised, so singular values are
comparable across outputs; the rank counts singular values above
``threshold * sigma_max``.

(5.17): the gyro-only map loses rank where ``a31 = -g c1 / r1`` or
``a42 = d omega2' / d theta2`` vanish; :func:`observability_along` reports
those entries so the loss can be checked against them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import EstimatorParams
from ...systems.ekf_model import jacobians, kinematic_f, kinematic_h
from ...io import Result
from .estimation_plots import plot_observability
from dataclasses import replace
from ..model.linearization import hanging_linearization
from ...systems.ekf import state_layout
from ...systems.ekf_model import GROUP_NOISE

DEFAULT_THRESHOLD = 1e-3


@dataclass
class ObservabilityResult(Result):
    """Observability along a trajectory: relative smallest singular values of the observability
    matrix (gyro only and full) at each time (s), the A entries a31, a42 and the rank-loss
    events."""
    t: np.ndarray
    rank_gyro: np.ndarray
    rank_full: np.ndarray
    smin_gyro: np.ndarray      # relative smallest singular value (scaled)
    smin_full: np.ndarray
    a31: np.ndarray
    a42: np.ndarray
    threshold: float
    events: list[dict]         # (5.17) points: a31 or a42 exactly zero

    def table(self) -> dict:
        """The ranks and relative smallest singular values (gyros alone, all
        sensors) and the (5.17) coefficients along the trajectory."""
        return {name: getattr(self, name) for name in
                ("t", "rank_gyro", "rank_full", "smin_gyro", "smin_full", "a31", "a42")}

    def plot(self, axes=None):
        """Relative smallest singular values and the A entries against time (two axes)."""

        return plot_observability(self, axes)

    def summary(self) -> dict:
        """Smallest ranks, rank-loss events and their times as JSON-ready data."""
        ev_g = [e["rank_gyro"] for e in self.events]
        ev_f = [e["rank_full"] for e in self.events]
        return {
            "min_rank_gyro_only": int(min([*self.rank_gyro, *ev_g])),
            "min_rank_full": int(min([*self.rank_full, *ev_f])),
            "full_rank_fraction_gyro_only": float(np.mean(self.rank_gyro == 4)),
            "full_rank_fraction_full": float(np.mean(self.rank_full == 4)),
            "min_relative_singular_value_gyro_only": float(self.smin_gyro.min()),
            "min_relative_singular_value_full": float(self.smin_full.min()),
            "rank_threshold": self.threshold,
            "samples": len(self.t),
            "gyro_rank_loss_points": [
                {"t_s": e["t"], "where": e["where"], "rank_gyro_only": e["rank_gyro"],
                 "rank_full": e["rank_full"]} for e in self.events],
        }


def observability_matrix(A: np.ndarray, C: np.ndarray) -> np.ndarray:
    """[C; C A; ...; C A^(n-1)] of the pair (A, C)."""
    n = A.shape[0]
    blocks, M = [], C
    for _ in range(n):
        blocks.append(M)
        M = M @ A
    return np.vstack(blocks)


def _relative_svals(A: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Singular values of O built from the time-scaled ``A/||A||`` (so the
    blocks C A^k are comparable), relative to the largest."""
    w = np.linalg.norm(A, 2)
    O = observability_matrix(A / w if w > 0 else A, C)
    s = np.linalg.svd(O, compute_uv=False)
    return s / s[0]


def linearize_kinematics(x, u, p: EstimatorParams):
    """(A, B, C, D) of (5.14) at absolute state ``x`` and input ``u``."""
    x4 = np.asarray(x, dtype=float)[:4]
    u = np.asarray(u, dtype=float)
    _, A, B = jacobians(kinematic_f, x4, u, p)
    _, C, D = jacobians(kinematic_h, x4, u, p)
    return A, B, C, D


def _point(x, u, p, S, Sinv, threshold):
    Cr = np.array([[0, 0, 1.0, 0], [0, 0, 0, 1.0]])
    A, _, C, _ = linearize_kinematics(x, u, p)
    As = Sinv @ A @ S  # scaled coordinates x = S xs
    sg = _relative_svals(As, Cr @ S)
    sf = _relative_svals(As, C @ S)
    return (int(np.sum(sg > threshold)), int(np.sum(sf > threshold)), sg[-1], sf[-1],
            A[2, 0], A[3, 1])


def observability_along(t, x_abs, u, p: EstimatorParams, *, threshold: float = DEFAULT_THRESHOLD,
                        angle_scale: float = 1.0, rate_scale: float = 3.0) -> ObservabilityResult:
    """Rank and relative smallest singular value of O along a trajectory.

    ``x_abs`` (N, 4) absolute states, ``u`` (N, 2) tangential accelerations.
    Sign changes of ``a31`` or ``a42`` between samples are refined by
    bisection on the linearly interpolated trajectory and evaluated exactly
    there (``events``): that is where (5.17) predicts the gyro-only map to
    lose rank.
    """

    p4 = replace(p, estimate_bias=False, estimate_misalignment=False)   # the four angles and rates
    S = np.diag([angle_scale, angle_scale, rate_scale, rate_scale])
    Sinv = np.linalg.inv(S)
    x_abs, u, t = np.asarray(x_abs, float), np.asarray(u, float), np.asarray(t, float)
    rows = np.array([_point(x_abs[k], u[k], p4, S, Sinv, threshold) for k in range(len(t))])
    events = []
    for col, name in ((4, "a31 = 0"), (5, "a42 = 0")):
        y = rows[:, col]
        for k in np.nonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)[0]:
            lo, hi = 0.0, 1.0
            f = lambda lam: _point(x_abs[k] + lam * (x_abs[k + 1] - x_abs[k]),
                                   u[k] + lam * (u[k + 1] - u[k]), p4, S, Sinv, threshold)
            ylo = y[k]
            for _ in range(60):
                mid = 0.5 * (lo + hi)
                ym = f(mid)[col]
                if np.sign(ym) == np.sign(ylo):
                    lo, ylo = mid, ym
                else:
                    hi = mid
            lam = 0.5 * (lo + hi)
            rg, rf, sg, sf, a31, a42 = f(lam)
            events.append({"t": float(t[k] + lam * (t[k + 1] - t[k])), "where": name,
                           "rank_gyro": rg, "rank_full": rf, "smin_gyro": float(sg),
                           "smin_full": float(sf), "a31": float(a31), "a42": float(a42)})
    events.sort(key=lambda e: e["t"])
    return ObservabilityResult(t, rows[:, 0].astype(int), rows[:, 1].astype(int), rows[:, 2],
                               rows[:, 3], rows[:, 4], rows[:, 5], threshold, events)


def zero_crossings(t, y) -> np.ndarray:
    """Times where ``y`` changes sign (linear interpolation)."""
    t, y = np.asarray(t), np.asarray(y)
    k = np.nonzero(np.sign(y[:-1]) * np.sign(y[1:]) < 0)[0]
    return t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])


def drake_is_observable(A, C, threshold: float | None = None) -> bool:
    """Drake's ``IsObservable`` on the linear system (A, 0, C, 0)."""
    from pydrake.systems.primitives import IsObservable, LinearSystem

    n = A.shape[0]
    sys = LinearSystem(A, np.zeros((n, 1)), C, np.zeros((C.shape[0], 1)))
    return bool(IsObservable(sys, threshold) if threshold is not None else IsObservable(sys))


def plant_gyro_observability(params, threshold: float = 1e-6) -> dict:
    """Drake's ``IsObservable`` on the linearised plant + friction at rest
    with gyro outputs (omega1, omega2 = q1d, q1d + q2d), scaled and raw."""

    lin = hanging_linearization(params)
    C = np.array([[0, 0, 1.0, 0], [0, 0, 1.0, 1.0]])
    O = observability_matrix(lin.A, C)
    s = np.linalg.svd(O, compute_uv=False)
    # scale by the fast elbow mode so the matrix powers stay comparable
    w = np.abs(lin.eigenvalues).max()
    As, Cs = lin.A / w, C
    return {"is_observable_raw": drake_is_observable(lin.A, C),
            "is_observable_scaled": drake_is_observable(As, Cs, threshold),
            "threshold_scaled": threshold,
            "condition_number_raw": float(s[0] / s[-1]),
            "time_scale_s": 1.0 / w}


#: the self-calibration states and their units, in state order
CALIBRATION_STATES = {"bias": ("gyro bias", "rad/s"), "misalign": ("misalignment", "rad"),
                      "scale": ("gyro scale error", "1"), "position": ("IMU distance", "m")}


def calibration_identifiability(result, params: EstimatorParams,
                                threshold: float = 0.3) -> list[dict]:
    """Which calibration states a log identifies.

    For every calibration state of the filter (gyro bias, accelerometer
    misalignment, gyro scale, IMU distance; per IMU) the filter's standard
    deviation at the end of the log (``result.cov_diag``, the EKF's own
    covariance, which already weighs the log's information against the
    process noise) is compared with the prior's (``*_sigma0``).  A state is
    *identified* when the ratio is below ``threshold`` (0.3: the log holds
    at least 10x the prior's information about it).  Where the linearised
    model cannot tell a state from the others (a misalignment while the
    links are still, a gyro scale or an IMU distance without motion) the
    ratio stays near 1: that is the observability check on real data.
    The ratio is about the filter's model; it assumes its noise levels."""

    layout, _ = state_layout(params)
    prior = {g: getattr(params, fields[0]) for g, fields in GROUP_NOISE.items()}
    rows = []
    for group, (label, unit) in CALIBRATION_STATES.items():
        if group not in layout:
            continue
        for i, k in enumerate(range(layout[group].start, layout[group].stop)):
            sigma = float(np.sqrt(result.cov_diag[-1, k]))
            value = _state_value(result, group, i)
            rows.append({"state": f"{label} {i + 1}", "group": group, "unit": unit,
                         "estimate": value, "sigma": sigma, "prior_sigma": prior[group],
                         "ratio": sigma / prior[group],
                         "identified": bool(sigma / prior[group] < threshold)})
    return rows


def _state_value(result, group: str, i: int) -> float:
    """The final estimate of a calibration state (smoothed when available)."""
    names = {"bias": ("gyro_bias", "smoothed_bias"),
             "misalign": ("misalignment", "smoothed_misalignment"),
             "scale": ("gyro_scale", "smoothed_gyro_scale"),
             "position": ("imu_position", "smoothed_imu_position")}[group]
    smoothed = getattr(result, names[1])
    values = smoothed if smoothed is not None else getattr(result, names[0])
    return float(values[-1, i])
