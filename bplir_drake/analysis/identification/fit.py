"""The calibration's fit (4.5): model parameters fitted by least squares to
one or several logged runs at once, and leave-one-log-out cross-validation.

The fit runs Drake simulations of the model driven by each log's torque
from its first state (:func:`~.calibration.simulate_log`) and compares the
joint angles (scipy's ``least_squares``).  Approximate standard errors come
from the Jacobian at the optimum: ``cov = s^2 (J^T J)^-1`` with ``s^2 =
SSR / (N - p)``.  A mass or inertia is fitted within ``bounds`` (factors of
its starting value), a friction coefficient within fixed ranges, a centre
of mass along its link.
"""
from __future__ import annotations

import dataclasses as dc
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...io import Result, WallClockLimit
from ...params import BplirParams, save_toml
from ...plotting import figure_axes, finish
from ...progress import progress_bar
from ...systems.plant import bias_term, gravity_vector, mass_matrix
from .calibration import (FITTABLE, RELATIVE_BOUNDS, CalibrationLog, _with, simulate_log)
from .calibration_error import CalibrationError


def _rms(d) -> float:
    return float(np.sqrt(np.mean(np.asarray(d) ** 2)))


@dataclass
class CalibrationResult(Result):
    """A fit of model parameters to logs: the names and fitted values with
    their standard errors, RMSE (rad) over all logs before and after, the
    calibrated parameters, each log with its simulated angles before and
    after, the simulations run and the parameters that ended at a bound."""
    names: tuple
    values: np.ndarray
    std_errors: np.ndarray
    rmse_before: float
    rmse_after: float
    params: BplirParams
    logs: list
    before: list
    after: list
    nfev: int
    at_bound: tuple = ()

    def plot(self, axes=None):
        """Each log against the simulation before and after the fit (two axes)."""
        return plot_calibration(self, axes)

    def summary(self) -> dict:
        """Fitted values and RMSE before and after (and per log) as JSON-ready data."""
        return {"fitted": {n: float(v) for n, v in zip(self.names, self.values)},
                "std_errors": {n: float(s) for n, s in zip(self.names, self.std_errors)},
                "rmse_before_rad": self.rmse_before, "rmse_after_rad": self.rmse_after,
                "rmse_after_per_log_rad": [_rms(a - g.q) for a, g in zip(self.after, self.logs)],
                "logs": len(self.logs), "at_bound": list(self.at_bound),
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


def check_bounds(bounds) -> tuple[float, float]:
    """``(lo, hi)`` factors of a mass's or inertia's starting value, checked:
    ``0 < lo < 1 < hi`` and finite."""
    lo, hi = (float(b) for b in bounds)
    if not (0.0 < lo < 1.0 < hi < math.inf):
        raise CalibrationError(f"bounds = {lo:g}, {hi:g} (factors of the starting values) are "
                               "not allowed; allowed 0 < low < 1 < high")
    return lo, hi


def _limits(params: BplirParams, fit, x0, bounds):
    lo = np.array([x * bounds[0] if FITTABLE[n][1] == "rel" else FITTABLE[n][1]
                   for n, x in zip(fit, x0)])
    hi = np.array([x * bounds[1] if FITTABLE[n][2] == "rel"
                   else FITTABLE[n][2] if FITTABLE[n][2] is not None
                   else getattr(params.plant, "l1" if n == "lc1" else "l2")
                   for n, x in zip(fit, x0)])
    outside = [n for n, x, a, b in zip(fit, x0, lo, hi) if not a <= x <= b]
    if outside:
        n = outside[0]
        k = fit.index(n)
        raise CalibrationError(f"{n} starts at {x0[k]:g}, outside the range it is fitted in; "
                               f"allowed [{lo[k]:g}, {hi[k]:g}]")
    return lo, hi


#: the least-squares fit's most residual evaluations (each with a finite-difference
#: Jacobian of one simulation per fitted parameter)
MAX_FIT_STEPS = 60


def calibrate(params: BplirParams, logs, fit=("fv1", "fv2", "fc1", "fc2"), *,
              bounds=RELATIVE_BOUNDS, accuracy: float = 1e-5,
              progress: bool = False) -> CalibrationResult:
    """Least squares on the joint angles (4.5) of one log or several fitted
    jointly; ``params`` is the start.  ``bounds``: the factors of a mass's or
    inertia's starting value it is fitted within.  ``accuracy``: the
    integrator's relative accuracy during the fit (1e-5 gives the 1e-6 fit
    in 85 simulations instead of 100; at 1e-4 the finite-difference Jacobian
    sees the integrator's error and fc1 comes out 25 % off); the final
    residual is at 1e-6.  ``progress``: count the simulations on standard
    error."""
    from scipy.optimize import least_squares

    logs = [logs] if isinstance(logs, CalibrationLog) else list(logs)
    fit = tuple(fit)
    bad = [n for n in fit if n not in FITTABLE]
    if bad or not fit or not logs:
        raise CalibrationError(f"cannot fit {', '.join(bad) or 'nothing'}; allowed: "
                               + ", ".join(FITTABLE))
    bounds = check_bounds(bounds)
    start = time.perf_counter()
    before = [simulate_log(params, g, accuracy=accuracy) for g in logs]   # the given model
    each = time.perf_counter() - start
    if {"fv1", "fv2", "fc1", "fc2"} <= set(fit):   # linear pre-fit of the friction
        start = friction_from_inverse_dynamics(params, max(logs, key=lambda g: len(g.t)))
        params = params.with_(friction=dc.replace(params.friction, **{
            k: float(v) for k, v in start.items() if v > 0}))
    x0 = np.array([getattr(params.friction if FITTABLE[n][0] == "friction" else params.plant, n)
                   for n in fit])
    lo, hi = _limits(params, fit, x0, bounds)
    scale = np.maximum(np.abs(x0), 1e-3)
    count = [0]
    most = MAX_FIT_STEPS * (1 + len(fit))   # each step: a residual and its Jacobian's columns
    bar = progress_bar(progress, desc="calibrate", unit="simulations", total=most)
    bar.set_postfix_str(f"at most {most} simulations of {each:.2g} s: "
                        f"{most * each / 60:.1f} min")
    size = sum(2 * len(g.t) for g in logs)

    def residuals(z):
        count[0] += 1
        bar.update()
        try:
            p = _with(params, fit, z * scale)
            return np.concatenate([(simulate_log(p, g, accuracy=accuracy) - g.q).ravel()
                                   for g in logs])
        except WallClockLimit:   # a stalled simulation ends the calibration
            raise
        except Exception:  # an impossible parameter set: a large, finite residual
            return np.full(size, 10.0)

    with bar:
        # dogbox: trf's scaling near the bounds (fc1 sits near 0) zig-zags
        res = least_squares(residuals, x0 / scale, bounds=(lo / scale, hi / scale),
                            method="dogbox", x_scale="jac", diff_step=1e-3, xtol=1e-6,
                            ftol=1e-8, max_nfev=MAX_FIT_STEPS)
    values = res.x * scale
    J = res.jac / scale
    s2 = float(res.fun @ res.fun) / max(1, res.fun.size - len(fit))
    try:
        se = np.sqrt(np.clip(np.diag(s2 * np.linalg.inv(J.T @ J)), 0, None))
    except np.linalg.LinAlgError:
        se = np.full(len(fit), math.inf)
    fitted = _with(params, fit, values)
    after = [simulate_log(fitted, g) for g in logs]
    edge = tuple(n for n, v, a, b in zip(fit, values, lo, hi)
                 if min(v - a, b - v) <= 1e-6 * max(abs(v), 1e-9))
    joined = lambda sims: np.concatenate([(s - g.q).ravel() for s, g in zip(sims, logs)])  # noqa: E731
    return CalibrationResult(fit, values, se, _rms(joined(before)), _rms(joined(after)), fitted,
                             logs, before, after, count[0], edge)


@dataclass
class CrossValidation(Result):
    """Leave-one-log-out: for each log, the fit to the others and the RMSE
    (rad) it leaves on the log held out, against the starting model's."""
    names: tuple
    values: np.ndarray        # (folds, parameters)
    held_out_before: np.ndarray
    held_out_after: np.ndarray

    def summary(self) -> dict:
        """Each fold's fitted values and held-out RMSE, and their means."""
        return {"folds": [{"fitted": dict(zip(self.names, map(float, v))),
                           "held_out_rmse_before_rad": float(b),
                           "held_out_rmse_after_rad": float(a)}
                          for v, b, a in zip(self.values, self.held_out_before,
                                             self.held_out_after)],
                "mean_held_out_rmse_before_rad": float(np.mean(self.held_out_before)),
                "mean_held_out_rmse_after_rad": float(np.mean(self.held_out_after)),
                "spread": {n: float(np.ptp(self.values[:, k])) for k, n in enumerate(self.names)}}


def cross_validate(params: BplirParams, logs, fit, **kw) -> CrossValidation:
    """Fit to all logs but one, each in turn (:func:`calibrate`, the same
    keyword arguments), and measure the fit on the log left out."""
    logs = list(logs)
    if len(logs) < 2:
        raise CalibrationError(f"cross-validation needs at least 2 logs; given {len(logs)}")
    values, before, after = [], [], []
    for k, held in enumerate(logs):
        res = calibrate(params, logs[:k] + logs[k + 1:], fit, **kw)
        values.append(res.values)
        before.append(_rms(simulate_log(params, held) - held.q))
        after.append(_rms(simulate_log(res.params, held) - held.q))
    return CrossValidation(tuple(fit), np.array(values), np.array(before), np.array(after))


def write_calibrated_toml(result: CalibrationResult, path) -> Path:
    """The calibrated parameters as a TOML parameter file at ``path`` (atomic)."""
    path = Path(path)
    save_toml(result.params, path)
    return path


def plot_calibration(result: CalibrationResult, axes=None):
    """The logged angles against the simulation before and after the fit,
    the logs one after another (two axes); returns the figure."""
    fig, ax = figure_axes(axes, 2, 1, figsize=(10, 6), sharex=True)
    start = 0.0
    for k, (g, b, a_) in enumerate(zip(result.logs, result.before, result.after)):
        t = g.t + start
        for i, a in enumerate(ax):
            first = k == 0
            a.plot(t, g.q[:, i], "k", lw=2, alpha=0.4, label="logged" if first else None)
            a.plot(t, b[:, i], "C3:", lw=1, label="model before" if first else None)
            a.plot(t, a_[:, i], "C0", lw=1, label="calibrated model" if first else None)
            if k:
                a.axvline(start, color="0.5", lw=0.8)
        start = t[-1] + 0.1 * (t[-1] - t[0])
    for i, a in enumerate(ax):
        a.set_ylabel(f"q{i + 1} [rad]")
        a.grid(True, alpha=0.3)
        a.legend(fontsize=8, loc="upper right")
    ax[1].set_xlabel("time [s]" + (" (logs one after another)" if len(result.logs) > 1 else ""))
    return finish(fig, f"Calibration (Fig. 4.7 style): RMSE {result.rmse_before:.4f} -> "
                       f"{result.rmse_after:.4f} rad")
