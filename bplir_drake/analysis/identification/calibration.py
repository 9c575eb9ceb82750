"""System identification (4.5)-(4.7): calibrate the plant to logged runs,
identify the dead-band, identify the CPFL plant family.

* the logs (:func:`read_calibration_csv`) and the model driven by their
  torque (:func:`simulate_log`, :func:`acrobot_log_angles`); the fit of
  friction, inertias, centres of mass and masses to one log or several --
  a free swing followed by elbow torque, as in Fig. 4.7 -- is
  :func:`.fit.calibrate`, with :func:`.fit.cross_validate`.
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
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...csvfile import csv_rows
from ...io import atomic_path

from ...params import BplirParams
from ...diagrams import build_free_swing
from ...diagrams.open_loop import build_acrobot, set_acrobot
from ...simulate import Log, logs, make_simulator, run
from .calibration_error import CalibrationError

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
                         torque_sign: float = 1.0, columns: dict | None = None,
                         span: tuple | None = None, torque: bool = True) -> CalibrationLog:
    """A calibration CSV (t, q1, q2 and tau in N m or i_cmd in A, converted with
    ``torque_per_amp``, times ``torque_sign``) as a checked
    :class:`CalibrationLog` spanning at least ``min_duration`` s; a bad file
    raises :class:`CalibrationError`.  ``columns`` names the file's column
    of each of t, q1, q2, q1d, q2d, tau, i_cmd it gives another name;
    ``span = (start, end)`` keeps the rows of that stretch of the log's
    clock (s; the first kept row's rates start the replay).  ``torque =
    False``: a log of the angles alone will do (its torque read as 0)."""
    path = Path(path)
    header, body = csv_rows(path, "log", CalibrationError)
    header = _renamed(header, columns or {}, path)
    missing = [c for c in CALIBRATION_COLUMNS if c not in header]
    if missing or (torque and not ({"tau", "i_cmd"} & set(header))):
        need = missing + ([] if not torque or {"tau", "i_cmd"} & set(header)
                          else ["tau or i_cmd"])
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
    if span is not None and len(data):
        data = data[(data[:, idx["t"]] >= span[0]) & (data[:, idx["t"]] <= span[1])]
    t = data[:, idx["t"]] if len(data) else np.zeros(0)
    q = data[:, [idx["q1"], idx["q2"]]] if len(data) else np.zeros((0, 2))
    tau = (data[:, idx["tau"]] if "tau" in idx
           else data[:, idx["i_cmd"]] * torque_per_amp if "i_cmd" in idx
           else np.zeros(len(data)))   # a log of the angles alone (torque = False)
    qd0 = (np.array([data[0, idx["q1d"]], data[0, idx["q2d"]]])
           if {"q1d", "q2d"} <= set(idx) and len(data) else None)
    return check_calibration_log(t, q, torque_sign * tau, qd0, min_duration=min_duration)


def _renamed(header: list, columns: dict, path) -> list:
    """``header`` with the file's columns named in ``columns`` (our name ->
    the file's) given our names; a column of the file already called by one
    of those names is set aside."""
    unknown = sorted(set(columns) - LOG_COLUMNS)
    if unknown:
        raise CalibrationError(f"log columns: unknown name(s) {', '.join(unknown)}; allowed: "
                               + ", ".join(sorted(LOG_COLUMNS)))
    absent = [f for f in columns.values() if f not in header]
    if absent:
        raise CalibrationError(f"log {path} has no column(s) {', '.join(absent)}; its columns: "
                               + ", ".join(header))
    ours = {f: n for n, f in columns.items()}
    return [ours[h] if h in ours else (f"_{h}" if h in columns else h) for h in header]


#: the columns a log may give (joint angles, rates, time, torque or current)
LOG_COLUMNS = {"t", "q1", "q2", "q1d", "q2d", "tau", "i_cmd"}


def in_package_angles(log: CalibrationLog, description) -> CalibrationLog:
    """A log in a robot description's joint coordinates
    (:class:`~bplir_drake.params.robot_file.RobotDescription`) in the
    package's angles, rates and torque."""
    x = description.from_file_state(np.c_[log.q, np.zeros((len(log.t), 2))])
    qd0 = None if log.qd0 is None else description.from_file_state(
        np.r_[log.q[0], log.qd0])[2:]
    return dc.replace(log, q=x[:, :2], tau=description.sign2 * log.tau, qd0=qd0)


#: plausible values of a calibration log: the elbow torque (10x the motor's
#: limit), the joint angles (a few turns), the initial rates, the span (s)
MAX_LOG_TORQUE, MAX_LOG_ANGLE, MAX_LOG_RATE, MAX_LOG_DURATION = 200.0, 50.0, 100.0, 600.0
#: the longest time between two rows of a log, in its median sampling periods
#: (the torque held across a longer hole is a guess, not the log)
MAX_LOG_GAP = 5.0


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
        values = np.asarray(values, dtype=float).ravel()
        if not np.all(np.isfinite(values)) or np.any(np.abs(values) > limit):
            worst = values[np.argmax(np.where(np.isfinite(values), np.abs(values), np.inf))]
            raise CalibrationError(f"log column {name}: {worst:g} is not plausible; allowed "
                                   f"[-{limit:g}, {limit:g}] {unit}")
    if len(t) < 20 or t[-1] - t[0] < min_duration:
        dur = (t[-1] - t[0]) if len(t) else 0.0
        raise CalibrationError(f"log is too short: {len(t)} samples over {dur:.2f} s; need at "
                               f"least 20 samples and {min_duration:g} s")
    gaps = np.diff(t)
    if np.any(gaps <= 0):
        k = int(np.argmax(gaps <= 0))
        raise CalibrationError(f"time is not increasing at row {k + 2}")
    step = float(np.median(gaps))
    if np.any(gaps > MAX_LOG_GAP * step):
        k = int(np.argmax(gaps > MAX_LOG_GAP * step))
        raise CalibrationError(f"time jumps by {gaps[k]:g} s at row {k + 2} (t = {t[k + 1]:g} s "
                               f"after {t[k]:g} s); allowed at most {MAX_LOG_GAP:g} times the "
                               f"log's median sampling period ({step:g} s) between "
                               "rows: the torque is not known across a hole")
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


def simulate_log(params: BplirParams, log: CalibrationLog, *, accuracy: float = 1e-6,
                 interpolation: str = "zoh") -> np.ndarray:
    """Joint angles of the (nominal) model driven by the logged torque (held
    between samples, or ``interpolation = "linear"``)."""

    p = params.with_(true_plant=None, true_friction=None)
    period = float(np.median(np.diff(log.t)))
    built = build_free_swing(p, (log.t, log.tau), log_period=period,
                             interpolation=interpolation)
    return _sampled_angles(built, log, period, accuracy,
                           wall_limit=params.scenario.wall_limit)


def _sampled_angles(built, log: CalibrationLog, period: float, accuracy: float,
                    set_context=None, wall_limit=None) -> np.ndarray:
    """The angles of ``built`` at the log's times, started at its first state
    (by ``set_context`` when given, else the plant's positions and rates)."""
    start = (None, None) if set_context else (log.q[0], log.qd0)
    sim = make_simulator(built, *start, accuracy=accuracy, set_context=set_context)
    run(sim, float(log.t[-1]) + period,   # a logged sample past the log's last time
        wall_limit, "a simulation of the log")
    return Log.from_logger(built.loggers["state"], sim.get_context()).at(log.t)[:, :2]


def acrobot_log_angles(params: BplirParams, log: CalibrationLog, *, accuracy: float = 1e-8,
                       interpolation: str = "zoh") -> np.ndarray:
    """Joint angles of Drake's ``AcrobotPlant`` with the nominal links
    (centres of mass on the axes, viscous damping only:
    :func:`~bplir_drake.diagrams.open_loop.build_acrobot`) driven by the
    logged torque from the log's first state."""
    period = float(np.median(np.diff(log.t)))
    built = build_acrobot(params, (log.t, log.tau), log_period=period,
                          interpolation=interpolation)
    x0 = np.r_[log.q[0], log.qd0]
    return _sampled_angles(built, log, period, accuracy,
                           set_context=lambda ctx: set_acrobot(built, ctx, x0))


def _with(params: BplirParams, names, values) -> BplirParams:
    f, p = {}, {}
    for n, v in zip(names, values):
        (f if FITTABLE[n][0] == "friction" else p)[n] = float(v)
    return params.with_(friction=dc.replace(params.friction, **f),
                        plant=dc.replace(params.plant, **p))


# ----------------------------------------------------------- dead-band (4.6)


# ----------------------------------------------------------- plant family (4.7)


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
