"""Offline state estimation of logged IMU data with the kinematic EKF.

The same :func:`bplir_drake.systems.ekf.ekf_step` as the in-diagram filter
runs over arrays or a CSV log, with the gyro-integral baseline (5.41)
beside it.

Log format (CSV, header required, extra columns ignored)::

    t,gyro1,gyro2,acc1_x,acc1_y,acc2_x,acc2_y

in s, rad/s and m/s^2, IMU frames as in docs/concepts.md.  Bad logs raise
:class:`LogError` (one line naming the problem): missing columns,
non-numeric cells, non-increasing time, a sampling period more than 20 %
away from the configured one, or NaN in two or more consecutive rows.  An
*isolated* row with NaN readings is skipped: the filter predicts over it
(with the last valid accelerations) and does not update; the row is counted
in ``EstimateResult.skipped``.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .csvfile import LogError, numeric_columns
from .io import Result, atomic_path
from .params import EstimatorParams
from .systems.ekf import (EkfState, correct_sample, ekf_predict, ekf_update, initial_state,
                          prediction_input, split_sample, state_layout)
from .systems.imu import IMU_COLUMNS
from .plotting import figure_axes, finish
from .progress import progress_bar

LOG_COLUMNS = ("t",) + IMU_COLUMNS
EST_COLUMNS = ("t", "theta1", "theta2", "omega1", "omega2")
PERIOD_TOLERANCE = 0.2
#: rows of an estimate written at a time (memory for the text, not the log)
WRITE_CHUNK = 50_000
#: logs this long (samples) or longer show the filter's progress
PROGRESS_MIN_SAMPLES = 20_000


@dataclass
class ImuLog:
    """An IMU log: times (s), samples (N, 6) in ``IMU_COLUMNS`` order, and any further columns by
    name."""
    t: np.ndarray         # (N,)
    samples: np.ndarray   # (N, 6) in IMU_COLUMNS order
    extra: dict[str, np.ndarray]


@dataclass
class EstimateResult(Result):
    """The filter over a log: times (s), absolute estimate (N, 4), covariance diagonal, gyro-bias
    estimate (rad/s), the gyro-integral baseline (5.41), skipped rows."""
    t: np.ndarray
    x: np.ndarray             # (N, 4) theta1, theta2, omega1, omega2
    cov_diag: np.ndarray      # (N, n)
    gyro_bias: np.ndarray     # (N, 2)
    gyro_integral: np.ndarray  # (N, 2) baseline (5.41)
    skipped: int
    #: normalised innovation squared of each update (NaN where skipped)
    nis: np.ndarray | None = None
    #: the Rauch-Tung-Striebel smoother's absolute state, covariance
    #: diagonal and gyro biases (``estimate(..., smooth=True)``)
    smoothed: np.ndarray | None = None
    smoothed_cov_diag: np.ndarray | None = None
    smoothed_bias: np.ndarray | None = None
    #: self-calibration states (``estimate_misalignment``,
    #: ``estimate_gyro_scale``): the estimates (N, 2) of the causal filter
    #: and, with ``smooth``, of the smoother (None when not estimated)
    misalignment: np.ndarray | None = None
    gyro_scale: np.ndarray | None = None
    smoothed_misalignment: np.ndarray | None = None
    smoothed_gyro_scale: np.ndarray | None = None
    #: the IMU distances r1, r2 (m; ``estimate_imu_position``)
    imu_position: np.ndarray | None = None
    smoothed_imu_position: np.ndarray | None = None
    #: where each state sits in ``cov_diag`` (:func:`~bplir_drake.systems.ekf.state_layout`)
    layout: dict | None = None

    def plot(self, axes=None):
        """The estimated angles beside the gyro integral (5.41) (two axes)."""
        return plot_estimate(self.t, self.x, self.gyro_integral, axes)

    def table(self) -> dict:
        """The filter's estimate against time: angles and rates (absolute,
        rad and rad/s), gyro biases (rad/s)."""
        out = {"t": self.t}
        for k, name in enumerate(("theta1", "theta2", "omega1", "omega2")):
            out[name] = self.x[:, k]
        for k in range(2):
            out[f"gyro_bias{k + 1}"] = self.gyro_bias[:, k]
        return out

    def summary(self) -> dict:
        """Samples, span, skipped updates, the final estimate and gyro bias,
        the NIS check (and the smoother's start) as JSON-ready numbers."""
        out = {"samples": int(len(self.t)), "duration_s": float(self.t[-1] - self.t[0]),
               "skipped_updates": self.skipped, "final_estimate": self.x[-1].tolist(),
               "final_gyro_bias": self.gyro_bias[-1].tolist(), "nis": self.nis_check()}
        if self.smoothed is not None:
            out["smoothed_start"] = self.smoothed[0].tolist()
        return out

    def nis_check(self, confidence: float = 0.95) -> dict:
        """The mean NIS against its two-sided ``confidence`` band: for a
        consistent filter, ``N`` mean NIS is chi-square with ``4 N`` degrees
        of freedom (4 measurements per update)."""
        from scipy.stats import chi2

        v = self.nis[np.isfinite(self.nis)]
        n = len(v)
        lo, hi = (chi2.ppf(q, 4 * n) / n for q in ((1 - confidence) / 2, (1 + confidence) / 2))
        mean = float(v.mean())
        return {"mean_nis": mean, "band": [float(lo), float(hi)], "updates": n,
                "consistent": bool(lo <= mean <= hi)}


def read_imu_csv(path: str | Path) -> ImuLog:
    """Read and check an IMU log; see the module docstring for the format.
    Extra columns are kept when numeric and ignored otherwise.  The file is
    read as a stream: memory grows with the numbers kept, not the text."""
    path = Path(path)
    cols, extra = numeric_columns(path, "log", LOG_COLUMNS, LogError)
    n = len(cols["t"])
    if n < 2:
        raise LogError(f"log {path} has {n} data row(s); need at least 2")
    t = np.frombuffer(cols.pop("t"), dtype=float)
    samples = np.empty((n, len(IMU_COLUMNS)))
    for j, name in enumerate(IMU_COLUMNS):
        samples[:, j] = np.frombuffer(cols.pop(name), dtype=float)
    return ImuLog(t, samples, {h: np.frombuffer(v, dtype=float) for h, v in extra.items()})


#: the largest step between rows (in sampling periods) a log may have
MAX_GAP = 5.0
#: plausible readings: a gyro's (rad/s, 2000 deg/s is 35) and an
#: accelerometer's (m/s^2, 16 g is 157) full scale, with margin
MAX_RATE, MAX_ACCEL = 100.0, 500.0


def check_log(t, samples, period: float) -> np.ndarray:
    """Validate arrays; returns the mask of rows whose update is skipped."""
    t = np.asarray(t, dtype=float)
    samples = np.asarray(samples, dtype=float)
    if samples.ndim != 2 or samples.shape[1] != 6 or samples.shape[0] != t.shape[0]:
        raise LogError(f"IMU samples must be (N, 6) with N = len(t) = {t.shape[0]}, got "
                       f"{samples.shape}")
    if t.shape[0] < 2:
        raise LogError("log has fewer than 2 samples")
    if not np.all(np.isfinite(t)):
        raise LogError(f"time column has a missing or non-finite value at row "
                       f"{int(np.argmax(~np.isfinite(t))) + 1}")
    dt = np.diff(t)
    if np.any(dt <= 0):
        k = int(np.argmax(dt <= 0))
        raise LogError(f"time is not increasing at row {k + 2} (t = {t[k + 1]:g} s after "
                       f"{t[k]:g} s)")
    med = float(np.median(dt))
    if abs(med / period - 1.0) > PERIOD_TOLERANCE:
        raise LogError(f"sampling period {med:g} s differs from the configured "
                       f"{period:g} s by more than {PERIOD_TOLERANCE:.0%}; allowed "
                       f"[{period * (1 - PERIOD_TOLERANCE):g}, "
                       f"{period * (1 + PERIOD_TOLERANCE):g}] s")
    if np.any(dt > MAX_GAP * period):
        k = int(np.argmax(dt > MAX_GAP * period))
        raise LogError(f"time jumps by {dt[k]:g} s at row {k + 2} (t = {t[k + 1]:g} s after "
                       f"{t[k]:g} s); allowed at most {MAX_GAP:g} sampling periods "
                       f"({MAX_GAP * period:g} s) between rows")
    limits = np.array([MAX_RATE] * 2 + [MAX_ACCEL] * 4)
    bad = np.zeros(t.shape[0], dtype=bool)
    for j in range(6):   # column by column: no copy of the whole log
        col = samples[:, j]
        with np.errstate(invalid="ignore"):
            wild = np.abs(col) > limits[j]
        if np.any(wild):
            k = int(np.argmax(wild))
            raise LogError(f"row {k + 1} column {IMU_COLUMNS[j]}: {col[k]:g} is not a "
                           f"plausible reading; allowed [-{limits[j]:g}, {limits[j]:g}] "
                           f"{'rad/s' if j < 2 else 'm/s^2'}")
        bad |= ~np.isfinite(col)
    if bad[0]:
        raise LogError("the first sample has missing or non-finite readings")
    runs = bad[1:] & bad[:-1]
    if np.any(runs):
        k = int(np.argmax(runs))
        raise LogError(f"rows {k + 1} and {k + 2} both have missing or non-finite readings; "
                       "only isolated rows are skipped")
    return bad


def gyro_integral(t, samples, theta0, bias=(0.0, 0.0)) -> np.ndarray:
    """Baseline (5.41): angles from integrating the gyros, less ``bias``
    (rad/s), from ``theta0``."""
    t = np.asarray(t, dtype=float)
    g = np.nan_to_num(np.asarray(samples, dtype=float)[:, :2] - np.asarray(bias)[:2])
    dt = np.diff(t, prepend=t[0])
    return np.asarray(theta0, dtype=float)[:2] + np.cumsum(g * dt[:, None], axis=0)


def encoder_lead(t, encoder_angles, gyro, max_lead: float = 0.05) -> float | None:
    """The time (s) by which the encoder angles lead the gyro samples,
    estimated from the log alone, as a user lines up two clocks: the lead
    ``d`` at which the encoders' rate (central differences) read ``d``
    earlier best explains each gyro, fitted with its own scale and a
    cubic-in-time bias (so biases, their drift and scale errors do not
    shift it), on a 0.1 ms grid within +/-``max_lead``, refined by a
    parabola through the best three.  The noise-free encoder side is the
    one interpolated: interpolating the noisy gyros would halve their
    noise between samples and pull the estimate there.  Rows with a
    missing value are left out; None when the log is too short (about
    0.6 s) or an angle too still (rate spread below 0.01 rad/s) to tell."""
    t = np.asarray(t, dtype=float)
    enc = np.asarray(encoder_angles, dtype=float)[:, :2]
    gyro = np.asarray(gyro, dtype=float)[:, :2]
    ok = np.all(np.isfinite(enc), axis=1) & np.all(np.isfinite(gyro), axis=1)
    t, enc, gyro = t[ok], np.unwrap(enc[ok], axis=0), gyro[ok]
    rate = np.gradient(enc, t, axis=0)
    inner = (t >= t[0] + max_lead) & (t <= t[-1] - max_lead)
    if inner.sum() < 50 or np.min(np.std(rate[inner], axis=0)) < 0.01:
        return None   # too short or too still to line the clocks up
    leads = np.arange(-max_lead, max_lead + 1e-12, 1e-4)
    tau = (t[inner] - t[inner].mean()) / np.ptp(t[inner])
    drift = np.column_stack([tau ** k for k in range(4)])

    def residual(d):
        total = 0.0
        for i in range(2):
            M = np.column_stack([np.interp(t[inner] - d, t, rate[:, i]), drift])
            coef = np.linalg.lstsq(M, gyro[inner, i], rcond=None)[0]
            total += float(np.sum((gyro[inner, i] - M @ coef) ** 2))
        return total

    r = np.array([residual(d) for d in leads])
    k = int(np.clip(np.argmin(r), 1, len(r) - 2))
    den = r[k - 1] - 2 * r[k] + r[k + 1]
    step = 0.5 * (r[k - 1] - r[k + 1]) / den if den > 0 else 0.0
    return float(leads[k] + np.clip(step, -1, 1) * (leads[1] - leads[0]))


def aligned_truth(t, encoder_angles, lead: float) -> np.ndarray:
    """The encoder angles moved onto the IMU clock: read ``lead`` s earlier
    (:func:`encoder_lead`)."""
    t = np.asarray(t, dtype=float)
    enc = np.asarray(encoder_angles, dtype=float)
    return np.column_stack([np.interp(t - lead, t, enc[:, i]) for i in range(enc.shape[1])])


def estimate(t, samples, params: EstimatorParams, x0=(0.0, 0.0, 0.0, 0.0), *,
             calibrate_window: float = 0.0, progress: bool = False, smooth: bool = False,
             sigmas=None) -> EstimateResult:
    """Run the EKF over a log.

    ``x0`` is the initial absolute state.  With ``calibrate_window > 0`` the
    robot is assumed still for that many seconds at the start: the mean gyro
    reading there initialises the bias estimate (and is removed from the
    baseline).  ``progress``: the samples filtered so far, on standard
    error (shown for logs of 20 000 samples or more).  ``smooth``: also run
    the Rauch-Tung-Striebel backward pass over the same model (the
    extended RTS smoother; :func:`rts_smooth`).  ``sigmas`` = (angle,
    rate[, bias]) initial standard deviations (default ``p0_*``).  Every
    update's normalised innovation squared is kept (``nis``).
    """

    t = np.asarray(t, dtype=float)
    samples = np.asarray(samples, dtype=float)
    skip = check_log(t, samples, params.period)
    s = initial_state(params, x0, sigmas)
    layout, n = state_layout(params)
    bias0 = np.zeros(2)
    if calibrate_window > 0:
        win = (t - t[0] <= calibrate_window) & ~skip
        bias0 = samples[win, :2].mean(axis=0)
        if "bias" in layout:
            s.x[layout["bias"]] = bias0
    N = len(t)
    # kept per sample: the state, its variances and the states past the four
    xs, covs, more = np.zeros((N, 4)), np.zeros((N, n)), np.zeros((N, n - 4))
    nis = np.full(N, np.nan)
    # what the backward pass needs: priors, posteriors, transition Jacobians
    priors, posteriors, jacobians = [], [], []
    u_prev = radial_prev = None
    bar = progress_bar(progress and N >= PROGRESS_MIN_SAMPLES, desc="estimate", unit="samples",
                       total=N)
    for k in range(N):
        if k % 1000 == 999:
            bar.update(1000)
        A = None  # no transition into the first sample
        if skip[k]:  # predict over the missing sample, no update
            s, A = ekf_predict(s, u_prev, params, with_jacobian=True, radial=radial_prev)
            prior = s
        else:
            # turned back by the misalignment estimate (a no-op without it)
            z, u = split_sample(correct_sample(samples[k], s.x, params))
            if u_prev is not None:
                s, A = ekf_predict(s, prediction_input(u_prev, u, params), params,
                                   with_jacobian=True,
                                   radial=prediction_input(radial_prev, z[2:4], params))
            s, nu, S, prior = ekf_update(s, z, u, params, with_innovation=True,
                                         hold=t[k] - t[0] < params.calibrate_after)
            nis[k] = float(nu @ np.linalg.solve(S, nu))
            u_prev, radial_prev = u, z[2:4]
        if smooth:
            priors.append(prior)
            posteriors.append(s)
            jacobians.append(A)
        xs[k] = s.x[:4]
        covs[k] = np.diag(s.P)
        more[k] = s.x[4:]
    bar.close()

    base = gyro_integral(t, samples, x0, bias0)
    bias = _columns(more, layout, "bias")
    result = EstimateResult(t, xs, covs, np.zeros((N, 2)) if bias is None else bias, base,
                            int(skip.sum()), nis,
                            misalignment=_columns(more, layout, "misalign"),
                            gyro_scale=_columns(more, layout, "scale"),
                            imu_position=_columns(more, layout, "position"), layout=dict(layout))
    if smooth:
        _attach_smoothed(result, rts_smooth(priors, posteriors, jacobians), layout)
    return result


def _columns(X, layout: dict, name: str, first: int = 4):
    """The columns of state group ``name`` in ``X`` (whose column 0 is state
    ``first``); None when the filter has no such group."""
    if name not in layout:
        return None
    cut = layout[name]
    return X[:, cut.start - first:cut.stop - first]


def _attach_smoothed(result: EstimateResult, smoothed: list, layout: dict) -> None:
    """Put the smoother's states, variances and calibration states on ``result``."""
    X = np.array([e.x for e in smoothed])
    result.smoothed = X[:, :4]
    result.smoothed_cov_diag = np.array([np.diag(e.P) for e in smoothed])
    bias = _columns(X, layout, "bias", 0)
    result.smoothed_bias = np.zeros((len(X), 2)) if bias is None else bias
    result.smoothed_misalignment = _columns(X, layout, "misalign", 0)
    result.smoothed_gyro_scale = _columns(X, layout, "scale", 0)
    result.smoothed_imu_position = _columns(X, layout, "position", 0)


def rts_smooth(priors, posteriors, jacobians) -> list[EkfState]:
    """The Rauch-Tung-Striebel backward pass: ``priors[k]`` / ``posteriors[k]``
    are the filter's state before / after the update of sample k and
    ``jacobians[k]`` the transition Jacobian from k-1 to k (``[0]`` unused).  Returns the
    smoothed states ``x_k|N`` with their covariances."""
    N = len(posteriors)
    out = [None] * N
    out[-1] = posteriors[-1]
    for k in range(N - 2, -1, -1):
        post, prior_next, A = posteriors[k], priors[k + 1], jacobians[k + 1]
        # gain C = P_k|k A' P_k+1|k^-1 (P symmetric: solve instead of inverting)
        C = np.linalg.solve(prior_next.P, A @ post.P).T
        x = post.x + C @ (out[k + 1].x - prior_next.x)
        P = post.P + C @ (out[k + 1].P - prior_next.P) @ C.T
        out[k] = EkfState(x, 0.5 * (P + P.T))
    return out


def write_estimate_csv(result: EstimateResult, path: str | Path) -> Path:
    """The estimate as CSV at ``path`` (atomic)."""
    path = Path(path)
    cols = list(EST_COLUMNS) + ["gyr_theta1", "gyr_theta2", "bias1", "bias2",
                                "var_theta1", "var_theta2", "nis"]
    parts = [result.t, result.x, result.gyro_integral, result.gyro_bias,
             result.cov_diag[:, :2], result.nis]
    for names, values in ((("misalign1", "misalign2"), result.misalignment),
                          (("gyro_scale1", "gyro_scale2"), result.gyro_scale),
                          (("imu_r1", "imu_r2"), result.imu_position)):
        if values is not None:   # self-calibration states
            cols += list(names)
            parts.append(values)
    if result.smoothed is not None:  # the smoother beside the causal estimate
        cols += ["smooth_" + c for c in EST_COLUMNS[1:]] + ["smooth_bias1", "smooth_bias2",
                                                            "smooth_var_theta1",
                                                            "smooth_var_theta2"]
        parts += [result.smoothed, result.smoothed_bias, result.smoothed_cov_diag[:, :2]]
    with atomic_path(path) as tmp, open(tmp, "w") as f:
        f.write(",".join(cols) + "\n")
        for a in range(0, len(result.t), WRITE_CHUNK):   # a block of rows at a time
            block = np.column_stack([p[a:a + WRITE_CHUNK] for p in parts])
            np.savetxt(f, block, delimiter=",", fmt="%.9g")
    return path


def write_imu_csv(t, samples, path: str | Path, extra: dict | None = None) -> Path:
    """Write a log in the documented format (with optional extra columns)."""
    path = Path(path)
    extra = extra or {}
    cols = list(LOG_COLUMNS) + list(extra)
    data = np.column_stack([t, samples] + [np.asarray(v) for v in extra.values()])
    with atomic_path(path) as tmp:
        np.savetxt(tmp, data, delimiter=",", header=",".join(cols), comments="", fmt="%.9g")
    return path


__all__ = ["LogError", "ImuLog", "EstimateResult", "read_imu_csv", "check_log", "estimate",
           "gyro_integral", "write_estimate_csv", "write_imu_csv", "EkfState"]


def plot_estimate(t, estimate, gyro_integral, axes=None, *, truth=None, title="Kinematic EKF"):
    """Figs 5.4-5.7 style: angles (EKF, gyro integral, truth if known) and,
    with a truth, the angle errors of both."""
    rows = 3 if truth is not None else 2
    fig, axes = figure_axes(axes, rows, 1, figsize=(9, 2.8 * rows), sharex=True)
    for i, ax in enumerate(axes[:2]):
        if truth is not None:
            ax.plot(t, truth[:, i], "k", lw=2.2, alpha=0.35, label="truth")
        ax.plot(t, estimate[:, i], "C0", label="K-EKF")
        ax.plot(t, gyro_integral[:, i], "C3--", lw=1, label="gyro integral (5.41)")
        ax.set_ylabel(f"theta{i + 1} [rad]")
        ax.legend(loc="upper right", fontsize=8)
        ax.grid(True, alpha=0.3)
    if truth is not None:
        ax = axes[2]
        for i in range(2):
            ax.plot(t, estimate[:, i] - truth[:, i], f"C{i}", label=f"EKF error theta{i + 1}")
            ax.plot(t, gyro_integral[:, i] - truth[:, i], f"C{i}:",
                    label=f"GYR error theta{i + 1}")
        ax.axhline(0.05, color="grey", lw=0.8)
        ax.axhline(-0.05, color="grey", lw=0.8)
        lim = max(0.1, 1.2 * float(np.percentile(np.abs(estimate[:, :2] - truth[:, :2]), 99)))
        ax.set_ylim(-lim, lim)
        ax.set_ylabel("error [rad]")
        ax.legend(loc="upper right", fontsize=8, ncol=2)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("time [s]")
    return finish(fig, title)
