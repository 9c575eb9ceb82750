"""System identification (4.5)-(4.7): calibrate the plant to logged runs,
identify the dead-band, identify the CPFL plant family.

* :func:`calibrate` fits friction (and optionally inertias, CoM distances,
  masses within bounds) to a logged run -- a free swing followed by elbow
  torque, as in Fig. 4.7 -- by least squares (scipy) on the joint angles of
  Drake simulations driven by the logged torque.  Approximate standard errors
  come from the Jacobian at the optimum: ``cov = s^2 (J^T J)^-1`` with
  ``s^2 = SSR / (N - p)``.
* :func:`identify_deadband` ramps the elbow torque command slowly through the
  motor/driver model and reports the command at which the elbow starts to
  move, forward and reverse (4.6).
* :func:`identify_plant_family` runs step tests of the simulated CPFL loop
  (outer-loop signal ``v`` through the zero-order hold and the motor) and fits
  ``q2(s)/v(s) = g e^{-s Td} / (s (s + c))`` to each response -- after CPFL
  the elbow is an integrator with a friction-damped lag (the velocity
  responds like (4.16)'s first-order-with-delay model ``k/(a s + 1)`` with
  ``g = k/a``, ``c = 1/a``; this form stays well conditioned when the
  damping is small, as it is here: within a step test the elbow is nearly a
  double integrator) -- returning the parameter ranges for the QFT toolkit.
  Steps smaller than the dead-band (|a v| < 0.82 N m) produce no motion.

Log format (CSV, header required, extra columns ignored): ``t,q1,q2`` plus
``tau`` (elbow torque, N m) or ``i_cmd`` (current command, A; converted with
the motor's torque constant).  Optional ``q1d,q2d``: their first row gives
the initial rates (otherwise a quadratic fit over the first 0.15 s).
"""
from __future__ import annotations

import dataclasses as dc
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...csvfile import csv_rows
from ...io import atomic_path

from ...params import BplirParams
from ...io import Result
from .deadband import (  # noqa: F401 (re-exported)
    identify_deadband, cpfl_step_response, damped_integrator_response, fit_step, PlantFamilyFit, identify_plant_family)
from ...diagrams import build_free_swing
from ...simulate import Log, logs, make_simulator, run
from ...systems.plant import bias_term, gravity_vector, mass_matrix
from ...progress import progress_bar
from ...params import save_toml
from ...plotting import figure_axes, finish
from .errors import CalibrationError  # noqa: F401 (re-exported)

CALIBRATION_COLUMNS = ("t", "q1", "q2")
FITTABLE = {
    "fv1": ("friction", 0.0, 2.0), "fv2": ("friction", 0.0, 2.0),
    "fc1": ("friction", 0.0, 2.0), "fc2": ("friction", 0.0, 3.0),
    "I1": ("plant", "rel", "rel"), "I2": ("plant", "rel", "rel"),
    "lc1": ("plant", 0.0, None), "lc2": ("plant", 0.0, None),
    "m1": ("plant", "rel", "rel"), "m2": ("plant", "rel", "rel"),
}
#: a mass or inertia is fitted within these factors of its nominal value
#: (so a small robot's 0.0017 kg m^2 fits as a large one's 0.15 does)
RELATIVE_BOUNDS = (0.1, 10.0)
DEFAULT_FIT = ("fv1", "fv2", "fc1", "fc2")


@dataclass
class CalibrationLog:
    """A logged run to calibrate against: times (s), joint angles (N, 2) rad, elbow torque (N,) N m
    and the initial rates (rad/s)."""
    t: np.ndarray
    q: np.ndarray          # (N, 2)
    tau: np.ndarray        # (N,) elbow torque
    qd0: np.ndarray        # (2,) initial rates


def read_calibration_csv(path, torque_per_amp: float, *, min_duration: float = 2.0,
                         torque_sign: float = 1.0) -> CalibrationLog:
    """A calibration CSV (t, q1, q2 and tau in N m or i_cmd in A, converted with
    ``torque_per_amp``, times ``torque_sign``) as a checked
    :class:`CalibrationLog` spanning at least ``min_duration`` s; a bad file
    raises :class:`CalibrationError`."""
    path = Path(path)
    header, body = csv_rows(path, "log", CalibrationError)
    missing = [c for c in CALIBRATION_COLUMNS if c not in header]
    if missing or not ({"tau", "i_cmd"} & set(header)):
        need = missing + ([] if {"tau", "i_cmd"} & set(header) else ["tau or i_cmd"])
        raise CalibrationError(f"log {path} lacks column(s) {', '.join(need)}; required: "
                               "t,q1,q2 and tau (N m) or i_cmd (A)")
    used = [h for h in ("t", "q1", "q2", "tau", "i_cmd", "q1d", "q2d") if h in header]
    cols = [header.index(h) for h in used]   # other columns are ignored, text or numbers
    data = []
    for lineno, row in body:
        try:
            data.append([float(row[i]) for i in cols])
        except (ValueError, IndexError):
            raise CalibrationError(f"log {path} line {lineno}: a non-numeric or missing cell "
                                   f"in {', '.join(used)}") from None
    data = np.array(data) if data else np.zeros((0, len(used)))
    idx = {h: i for i, h in enumerate(used)}
    t = data[:, idx["t"]] if len(data) else np.zeros(0)
    q = data[:, [idx["q1"], idx["q2"]]] if len(data) else np.zeros((0, 2))
    tau = (data[:, idx["tau"]] if "tau" in idx else data[:, idx["i_cmd"]] * torque_per_amp) \
        if len(data) else np.zeros(0)
    qd0 = (np.array([data[0, idx["q1d"]], data[0, idx["q2d"]]])
           if {"q1d", "q2d"} <= set(idx) and len(data) else None)
    return check_calibration_log(t, q, torque_sign * tau, qd0, min_duration=min_duration)


#: plausible values of a calibration log: the elbow torque (10x the motor's
#: limit), the joint angles (a few turns), the initial rates, the span (s)
MAX_LOG_TORQUE, MAX_LOG_ANGLE, MAX_LOG_RATE, MAX_LOG_DURATION = 200.0, 50.0, 100.0, 600.0


def check_calibration_log(t, q, tau, qd0=None, *, min_duration: float = 2.0) -> CalibrationLog:
    """A :class:`CalibrationLog` from arrays, checked: at least 20 finite samples over
    ``min_duration`` seconds with increasing times (a row repeated whole counts once)."""
    t, q, tau = np.asarray(t, float), np.asarray(q, float), np.asarray(tau, float)
    if len(t) > 1:   # a row repeated whole (a logger's last sample written twice) is one row
        again = np.concatenate([[False], (np.diff(t) == 0) & np.all(np.diff(q, axis=0) == 0, axis=1)
                                & (np.diff(tau) == 0)])
        t, q, tau = t[~again], q[~again], tau[~again]
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q)) and np.all(np.isfinite(tau))):
        raise CalibrationError("log has missing or non-finite values")
    for name, values, limit, unit in (("tau", tau, MAX_LOG_TORQUE, "N m"),
                                      ("q1, q2", q, MAX_LOG_ANGLE, "rad"),
                                      ("q1d, q2d", np.zeros(2) if qd0 is None else qd0,
                                       MAX_LOG_RATE, "rad/s")):
        values = np.asarray(values, dtype=float)
        if not np.all(np.isfinite(values)) or np.any(np.abs(values) > limit):
            worst = values[np.argmax(np.where(np.isfinite(values), np.abs(values), np.inf))]
            raise CalibrationError(f"log column {name}: {worst:g} is not plausible; allowed "
                                   f"[-{limit:g}, {limit:g}] {unit}")
    if len(t) < 20 or t[-1] - t[0] < min_duration:
        dur = (t[-1] - t[0]) if len(t) else 0.0
        raise CalibrationError(f"log is too short: {len(t)} samples over {dur:.2f} s; need at "
                               f"least 20 samples and {min_duration:g} s")
    if np.any(np.diff(t) <= 0):
        k = int(np.argmax(np.diff(t) <= 0))
        raise CalibrationError(f"time is not increasing at row {k + 2}")
    if t[-1] - t[0] > MAX_LOG_DURATION:
        raise CalibrationError(f"log spans {t[-1] - t[0]:g} s; allowed at most "
                               f"{MAX_LOG_DURATION:g} s (simulation-error fitting of a chaotic "
                               "pendulum needs short logs)")
    if np.ptp(q[:, 0]) < 0.05 and np.ptp(q[:, 1]) < 0.05:
        raise CalibrationError(f"no excitation: the joints move by only {np.ptp(q[:, 0]):.3g} and "
                               f"{np.ptp(q[:, 1]):.3g} rad; need a swing of at least 0.05 rad")
    if qd0 is None:  # quadratic fit over the first 0.15 s
        n = max(3, int(np.searchsorted(t - t[0], 0.15)))
        qd0 = np.polyfit(t[:n + 1] - t[0], q[:n + 1], 2)[1]
    return CalibrationLog(t - t[0], q, tau, np.asarray(qd0, float))


def simulate_log(params: BplirParams, log: CalibrationLog, *, accuracy: float = 1e-6) -> np.ndarray:
    """Joint angles of the (nominal) model driven by the logged torque."""

    p = params.with_(true_plant=None, true_friction=None)
    period = float(np.median(np.diff(log.t)))
    built = build_free_swing(p, (log.t, log.tau), log_period=period)
    sim = make_simulator(built, log.q[0], log.qd0, accuracy=accuracy)
    run(sim, float(log.t[-1]) + period)   # a logged sample past the log's last time
    return Log.from_logger(built.loggers["state"], sim.get_context()).at(log.t)[:, :2]


def _with(params: BplirParams, names, values) -> BplirParams:
    f, p = {}, {}
    for n, v in zip(names, values):
        (f if FITTABLE[n][0] == "friction" else p)[n] = float(v)
    return params.with_(friction=dc.replace(params.friction, **f),
                        plant=dc.replace(params.plant, **p))


@dataclass
class CalibrationResult(Result):
    """A fit of model parameters to a log: the parameters before and after, the fitted values, RMSE
    (rad) before and after, and the simulated angles to plot."""
    names: tuple
    values: np.ndarray
    std_errors: np.ndarray
    rmse_before: float
    rmse_after: float
    params: BplirParams
    t: np.ndarray
    logged: np.ndarray
    before: np.ndarray
    after: np.ndarray
    nfev: int

    def plot(self, axes=None):
        """The log against the simulation before and after the fit (two axes)."""
        return plot_calibration(self, axes)

    def summary(self) -> dict:
        """Fitted values and RMSE before and after as JSON-ready data."""
        return {"fitted": {n: float(v) for n, v in zip(self.names, self.values)},
                "std_errors": {n: float(s) for n, s in zip(self.names, self.std_errors)},
                "rmse_before_rad": self.rmse_before, "rmse_after_rad": self.rmse_after,
                "simulations": self.nfev}


def friction_from_inverse_dynamics(params: BplirParams, log: CalibrationLog,
                                   window: float = 0.15) -> dict:
    """Linear least squares for (fv1, fv2, fc1, fc2): friction enters
    ``M q'' + C q' + g = tau - f`` linearly, so with q', q'' from a
    Savitzky-Golay filter of the logged angles the coefficients follow from
    one linear solve (the classic inverse-dynamics identification).  Used as
    the start of :func:`calibrate`."""
    from scipy.signal import savgol_filter


    dt = float(np.median(np.diff(log.t)))
    w = max(5, int(round(window / dt)) | 1)
    q = savgol_filter(log.q, w, 3, axis=0)
    qd = savgol_filter(log.q, w, 3, deriv=1, delta=dt, axis=0)
    qdd = savgol_filter(log.q, w, 3, deriv=2, delta=dt, axis=0)
    p, b = params.plant, params.friction.b
    rows, rhs = [], []
    for k in range(w, len(log.t) - w):
        M = mass_matrix(q[k], p)
        r = np.array([0.0, log.tau[k]]) - M @ qdd[k] - bias_term(q[k], qd[k], p) \
            - gravity_vector(q[k], p)          # = f(qd)
        a1, a2 = qd[k]
        rows.append([a1, 0, 2 / math.pi * math.atan(a1 / b), 0])
        rhs.append(r[0])
        rows.append([0, a2, 0, 2 / math.pi * math.atan(a2 / b)])
        rhs.append(r[1])
    theta = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
    return dict(zip(("fv1", "fv2", "fc1", "fc2"), np.maximum(theta, 0.0)))


def calibrate(params: BplirParams, log: CalibrationLog, fit=DEFAULT_FIT, *,
              accuracy: float = 1e-5, progress: bool = False) -> CalibrationResult:
    """Least squares on the joint angles (4.5); ``params`` is the start.
    ``accuracy``: the integrator's relative accuracy during the fit (1e-5
    gives the 1e-6 fit in 85 simulations instead of 100, each about 40 %
    faster; at 1e-4 the finite-difference Jacobian sees the integrator's
    error and fc1 comes out 25 % off); the final residual is at 1e-6.
    ``progress``: count the simulations (residual evaluations, Jacobian
    columns included) on standard error."""
    from scipy.optimize import least_squares

    fit = tuple(fit)
    bad = [n for n in fit if n not in FITTABLE]
    if bad or not fit:
        raise CalibrationError(f"cannot fit {', '.join(bad) or 'nothing'}; allowed: "
                               + ", ".join(FITTABLE))
    before = simulate_log(params, log, accuracy=accuracy)   # the given model
    if {"fv1", "fv2", "fc1", "fc2"} <= set(fit):   # linear pre-fit of the friction
        start = friction_from_inverse_dynamics(params, log)
        params = params.with_(friction=dc.replace(params.friction, **{
            k: float(v) for k, v in start.items() if v > 0}))
    x0 = np.array([getattr(params.friction if FITTABLE[n][0] == "friction" else params.plant, n)
                   for n in fit])
    lo = np.array([x * RELATIVE_BOUNDS[0] if FITTABLE[n][1] == "rel" else FITTABLE[n][1]
                   for n, x in zip(fit, x0)])
    hi = np.array([x * RELATIVE_BOUNDS[1] if FITTABLE[n][2] == "rel"
                   else FITTABLE[n][2] if FITTABLE[n][2] is not None
                   else getattr(params.plant, "l1" if n == "lc1" else "l2")
                   for n, x in zip(fit, x0)])
    scale = np.maximum(np.abs(x0), 1e-3)
    count = [0]
    bar = progress_bar(progress, desc="calibrate", unit="simulations")

    def residuals(z):
        count[0] += 1
        bar.update()
        try:
            sim = simulate_log(_with(params, fit, z * scale), log, accuracy=accuracy)
        except Exception:  # an impossible parameter set: a large, finite residual
            return np.full(2 * len(log.t), 10.0)
        return (sim - log.q).ravel()

    with bar:
        # dogbox: trf's scaling near the bounds (fc1 sits near 0) zig-zags
        # here, 51 iterations and 239 simulations against dogbox's 100
        res = least_squares(residuals, x0 / scale, bounds=(lo / scale, hi / scale),
                            method="dogbox", x_scale="jac", diff_step=1e-3, xtol=1e-6,
                            ftol=1e-8, max_nfev=60)
    values = res.x * scale
    J = res.jac / scale
    dof = max(1, res.fun.size - len(fit))
    s2 = float(res.fun @ res.fun) / dof
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
        se = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        se = np.full(len(fit), math.inf)
    fitted = _with(params, fit, values)
    after = simulate_log(fitted, log)
    rm = lambda d: float(np.sqrt(np.mean(d ** 2)))  # noqa: E731
    return CalibrationResult(fit, values, se, rm(before - log.q), rm(after - log.q), fitted,
                             log.t, log.q, before, after, count[0])


# ----------------------------------------------------------- dead-band (4.6)


# ----------------------------------------------------------- plant family (4.7)


def write_calibrated_toml(result: CalibrationResult, path) -> Path:
    """The calibrated parameters as a TOML parameter file at ``path`` (atomic)."""

    path = Path(path)
    save_toml(result.params, path)
    return path


def plot_calibration(result: CalibrationResult, axes=None):
    """The logged angles against the simulation before and after the fit (two axes); returns the
    figure."""
    fig, ax = figure_axes(axes, 2, 1, figsize=(10, 6), sharex=True)
    for i, a in enumerate(ax):
        a.plot(result.t, result.logged[:, i], "k", lw=2, alpha=0.4, label="logged")
        a.plot(result.t, result.before[:, i], "C3:", lw=1, label="model before")
        a.plot(result.t, result.after[:, i], "C0", lw=1, label="calibrated model")
        a.set_ylabel(f"q{i + 1} [rad]")
        a.grid(True, alpha=0.3)
        a.legend(fontsize=8, loc="upper right")
    ax[1].set_xlabel("time [s]")
    return finish(fig, f"Calibration (Fig. 4.7 style): RMSE {result.rmse_before:.4f} -> "
                            f"{result.rmse_after:.4f} rad")


def synthetic_log(params: BplirParams, *, q0=(0.8, 0.3), free_time: float = 6.0,
                  torque: float = 4.0, period: float = 1.5, torque_time: float = 6.0,
                  noise: float = 0.002, dt: float = 0.01, seed: int = 0) -> CalibrationLog:
    """A Fig. 4.7-style log of the *simulated* robot (``params.true_*``): a
    free swing, then an elbow torque square wave of +/- ``torque`` (so the
    elbow moves both ways), with white angle noise of ``noise`` rad."""

    T = free_time + torque_time
    t = np.arange(0.0, T + 1e-9, dt)
    tau = np.where(t < free_time, 0.0,
                   torque * np.sign(np.sin(2 * np.pi * (t - free_time) / period) + 1e-12))
    built = build_free_swing(params, (t, tau), log_period=dt)
    sim = make_simulator(built, q0, (0.0, 0.0), accuracy=1e-8)
    run(sim, T)
    st = logs(built, sim)["state"]
    q = st.at(t)[:, :2]
    q = q + noise * np.random.default_rng(seed).standard_normal(q.shape)
    return CalibrationLog(t, q, tau, np.zeros(2))


def write_calibration_csv(log: CalibrationLog, path) -> Path:
    """The documented log format, with the initial rates in ``q1d,q2d``."""
    path = Path(path)
    rates = np.zeros((len(log.t), 2))
    rates[0] = log.qd0
    data = np.column_stack([log.t, log.q, log.tau, rates])
    with atomic_path(path) as tmp:
        np.savetxt(tmp, data, delimiter=",", header="t,q1,q2,tau,q1d,q2d", comments="", fmt="%.9g")
    return path
