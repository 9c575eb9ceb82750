"""How the swing is controlled: the controller presets and loop settings, the path generator and plan tracker, the landing laws, and the named tunings and hardware options."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace
from .blocks import ParameterError, _Block, _count, _fraction, _p, _positive
import warnings
import numpy as _np


#: the swing's filter with the trapezoid step (``EstimatorParams`` fields),
#: which needs 10x the process noise of Heun's step, and no in-flight
#: misalignment estimate; the adaptive path's delay compensation and latch
#: were built with it
TRAPEZOID_TUNING = {"integration": "trapezoid", "accel_process_sigma": 2.0,
                    "accel_meas_sigma": 0.05, "estimate_misalignment": False}


#: the shooting landing's aim and hold of the robot without the jaw's line
#: sensor (the defaults; :func:`~.derive.imu_only`)
IMU_ONLY_TUNING = {"shoot_height": -0.015, "shoot_min_time": 0.04, "lift_law": "aim"}


#: the jaw's line sensor as a hardware option: its range, and the landing's
#: aim and hold with it (:func:`~.derive.with_hardware`)
LINE_SENSOR_OPTION = {"range": 0.2, "shoot_height": -0.018, "shoot_min_time": 0.03,
                      "lift_law": "shoot", "shoot_lift_min_time": 0.05}


#: the 48 V supply as a hardware option: the supply, a swing tried again from
#: hanging planned as the 30 V robot plans it (within the 30 V envelope: the
#: 48 V envelope alone lets the pump flip the elbow at 23 rad/s, faster than
#: the tracker follows; on the 30 V robot's pump the 48 V tracker has voltage
#: to spare, and the tries read the 30 V robot's plan libraries), and a
#: traversal's landing shot that brakes the elbow when it asks for more than
#: 1.6 times the torque the motor gives to lift the gripper (link 1 stopped
#: short, and chasing the line flings the elbow into it: a timed-out swing
#: is tried again from hanging at rest, a crash from its arrival's speed)
SUPPLY_48V_OPTION = {"supply_voltage": 48.0, "hanging_supply_voltage": 30.0, "shoot_brake_ratio": 1.6}


#: named hardware options on top of a preset (:func:`~.derive.with_hardware`)
HARDWARE_OPTIONS = {
    "line-sensor": "a range sensor in each gripper's jaw reading the line within 0.2 m",
    "48v": "a 48 V supply (the motor's datasheet rating) instead of the 30 V the robot has; "
           "a swing from hanging at the 30 V robot's pace",
}


# ---------------------------------------------------------------- controller
#: the controller presets, named for what they are: ``plan`` tracks a swing
#: planned by trajectory optimisation (time-varying LQR) and lands with its
#: landing law; ``cpfl-qft`` is the dissertation's CPFL inner loop with the
#: published QFT outer loop (6.23)-(6.24) and the path generator; ``lab``
#: is the lab firmware's proportional law
CONTROLLER_PRESETS = ("plan", "cpfl-qft", "lab")
#: former preset names, still accepted (with a one-line notice)
RENAMED_PRESETS = {"qft": "plan", "dissertation": "cpfl-qft"}


def current_preset_name(name):
    """The preset's current name; a former one (:data:`RENAMED_PRESETS`) is
    accepted with a one-line ``FutureWarning``."""
    if isinstance(name, str) and name in RENAMED_PRESETS:

        warnings.warn(f"controller preset '{name}' is now called '{RENAMED_PRESETS[name]}'",
                      FutureWarning, stacklevel=4)
        return RENAMED_PRESETS[name]
    return name


#: Outer-loop designs as continuous-time transfer functions (numerator,
#: denominator coefficients, highest power first) of ``K(s)`` acting on
#: ``e = F(r) - y`` and of the prefilter ``F(s)``.  ``cpfl-qft`` is
#: (6.23)-(6.24) as published (for the measured family (4.16), whose sign
#: is negative); ``lab`` is the firmware's proportional law (sign corrected
#: for the simulated plant q2'' = v, see docs/errata.md); ``plan`` carries,
#: for when its swing is steered by the path generator, a QFT design for
#: the plant family of the simulated CPFL loop by
#: :mod:`bplir_drake.analysis.control.qft` (``bplir qft --family diagram``
#: re-verifies it).
OUTER_LOOP_DESIGNS = {
    "cpfl-qft": {"k_num": (-216.0,), "k_den": (1.0,),
                     "f_num": (10.61,), "f_den": (1.0, 8.616)},
    "lab": {"k_num": (95.0,), "k_den": (1.0,), "f_num": (1.0,), "f_den": (1.0,)},
    # design_qft on diagram_family(seed=0, 60 plants); verified on seed 1
    "plan": {"k_num": (18.25195, 159.3015, 46.14857), "k_den": (0.004000074, 1.0, 0.0),
            "f_num": (860.6985,), "f_den": (1.0, 117.9063, 868.9110)},
}


@dataclass(frozen=True)
class ControllerParams(_Block):
    """CPFL inner loop + outer loop (chapter 6).  ``preset`` picks the outer
    loop design (see :data:`OUTER_LOOP_DESIGNS`); non-empty ``k_num`` ...
    ``f_den`` override it."""

    _name = "controller"
    preset: str = field(default="plan", metadata=dict(doc="the controller preset: plan (plan tracking with its landing), cpfl-qft (the dissertation's CPFL + QFT + path generator), lab (the lab firmware); former names qft, dissertation", allowed="plan, cpfl-qft, lab"))
    period: float = _p(0.01, "s", 0, 1, lo_open=True, doc="controller sample time Ts")
    torque_limit: float = _positive(20.0, "N m", doc="saturation in the controller")
    aw_gain: float = _p(100.0, "", 0, doc="anti-windup gain X >> 1 (Fig. 6.7); 0 disables")
    delay_samples: int = _count(0, "samples", 0, 1, doc="command applied this many samples late (0 or 1)")
    torque_quantum: float = _p(0.0, "N m", 0, 5, doc="truncate the torque to multiples of this (firmware: 1)")
    compute_latency: float = _p(3e-4, "s", 0, 0.01, doc="time from the IMU sample to the command reaching the driver (< period)")
    delay_compensation: float = _p(0.0, "s", 0, 0.1, doc="actuation delay the CPFL controller assumes (whole periods): it acts on the state predicted this far ahead (0: none)")
    friction_compensation: bool = field(default=False, metadata=dict(doc="CPFL includes the nominal friction in its feedback linearisation"))
    sign_correct: bool = field(default=True, metadata=dict(doc="negate a K of negative gain (the published K = -216 matches the measured plant's sign, see errata)"))
    plugin: str = field(default="", metadata=dict(doc="module:factory (or registered name) of your own controller ('' : the preset's)", allowed="module:factory, a registered name or ''"))
    plugin_args: tuple = field(default=(), metadata=dict(doc="keyword arguments of the plug-in's factory, each 'key=value' (numbers, true/false or text)"))
    k_num: tuple = field(default=(), metadata=dict(doc="outer-loop K numerator, highest power first (empty: the preset's design)"))
    k_den: tuple = field(default=(), metadata=dict(doc="outer-loop K denominator, highest power first"))
    f_num: tuple = field(default=(), metadata=dict(doc="prefilter F numerator, highest power first"))
    f_den: tuple = field(default=(), metadata=dict(doc="prefilter F denominator, highest power first"))

    def __post_init__(self):
        object.__setattr__(self, "preset", current_preset_name(self.preset))
        super().__post_init__()

    def _check(self):
        self._check_plugin()
        self._one_of("preset", CONTROLLER_PRESETS)
        if self.compute_latency >= self.period:
            raise ParameterError(
                f"controller.compute_latency = {self.compute_latency:g} s must be shorter "
                f"than controller.period = {self.period:g} s; allowed [0, period)")
        for name in ("k_num", "k_den", "f_num", "f_den"):
            v = getattr(self, name)
            if not isinstance(v, (tuple, list)) or not all(
                    isinstance(c, (int, float)) and not isinstance(c, bool)
                    and math.isfinite(c) for c in v):
                raise ParameterError(
                    f"controller.{name} = {v!r} must be a list of finite numbers")
            object.__setattr__(self, name, tuple(float(c) for c in v))
        for num, den in (("k_num", "k_den"), ("f_num", "f_den")):
            n, d = getattr(self, num), getattr(self, den)
            if bool(n) != bool(d):
                raise ParameterError(f"controller.{num} and controller.{den} must be given together")
            if d and (d[0] == 0 or len(n) > len(d)):
                raise ParameterError(
                    f"controller.{num}/{den} must be a proper transfer function with a "
                    "non-zero leading denominator coefficient")
        f_den = self.design["f_den"]
        if len(f_den) > 1:

            poles = _np.roots(f_den)
            if _np.any(poles.real >= 0):
                raise ParameterError(
                    f"controller prefilter F has poles {poles.tolist()} not in the open left "
                    "half plane; an unstable prefilter is not allowed")

    @classmethod
    def preset_named(cls, name: str, **overrides) -> "ControllerParams":
        """Controller parameters of a named preset (with its firmware quirks)."""
        name = current_preset_name(name)
        if name not in CONTROLLER_PRESETS:
            raise ParameterError(
                f"unknown controller preset '{name}'; allowed: " + ", ".join(CONTROLLER_PRESETS)
                + ", or module:factory (your own controller)")
        extra = {"lab": dict(aw_gain=0.0, delay_samples=1, torque_quantum=1.0)}.get(name, {})
        return cls(preset=name, **(extra | overrides))

    @property
    def design(self) -> dict:
        """The outer loop's K and F coefficients: the explicit ones if set, else the preset's."""
        d = dict(OUTER_LOOP_DESIGNS[self.preset])
        for key in ("k_num", "k_den", "f_num", "f_den"):
            if getattr(self, key):
                d[key] = getattr(self, key)
        return d


# ---------------------------------------------------------------- path
PATH_MODES = ("auto", "adaptive", "rts", "lab", "plan")






#: what ``path.mode = "auto"`` (the default) becomes, said once for the
#: parameter's doc, the command line's help and the docs
AUTO_PATH_MODE = ("plan (plan tracking) with the plan controller preset on every line, "
                  "adaptive (the path generator) with the other presets and plug-ins")


@dataclass(frozen=True)
class PathParams(_Block):
    """Online path generator (chapter 7).  ``mode``: ``auto`` (the default:
    :data:`AUTO_PATH_MODE`, :meth:`resolved`), ``adaptive`` (RTS +
    blend to line seeking with the adaptive blend end), ``rts`` (the RTS path
    with the blend (7.20)-(7.21) at its printed end, no adaptation),
    ``lab`` (the firmware's ``1.5 q1 q2f/q1f``) or ``plan`` (no path: a
    time-varying LQR tracks a trajectory-optimised swing: the ``plan``
    block, with its landing in the ``landing`` block)."""

    _name = "path"
    mode: str = field(default="auto", metadata=dict(doc=f"how the swing is steered: auto ({AUTO_PATH_MODE}), plan, adaptive, rts, lab", allowed="auto, plan, adaptive, rts, lab"))
    blend_exponent: float = _p(2.0, "", 1, 10, doc="exponent n of the blend weight F = (s/s_e)^n (7.20)")
    arrival_rate: float = _p(0.45, "rad/s", 0, 2, lo_open=True, doc="link-1 rate aimed for where the gripper enters the capture band")
    adapt_window: float = _p(0.3, "", 0, 1, doc="s_e adapts from s > -adapt_window * s_f ...")
    adapt_stop: float = _p(0.8, "", 0, 1, doc="... until s > adapt_stop * s_e")
    adapt_rate: float = _positive(0.3, "rad/s", doc="largest rate of change of s_e")
    blend_end_min: float = _p(0.75, "", 0.1, 1, doc="s_e >= this * s_f")
    blend_end_max: float = _p(1.5, "", 1, 3, doc="s_e <= this * s_f")
    predict_step: float = _p(0.005, "rad", 1e-4, 0.1, doc="RK4 step of the reduced-dynamics prediction")
    latch_rate: float = _p(0.3, "rad/s", 0, doc="latch to pure line seeking when q1' falls below this")
    latch_fraction: float = _p(0.85, "", 0, 1, doc="... and s >= this * s_e")
    latch_ramp: float = _positive(2.0, "1/s", doc="after the latch the blend weight rises to 1 at this rate")
    latch_lift: float = _p(0.01, "m", -0.1, 0.1, doc="after the latch the line-seeking path aims this far above the line (tracking error margin)")
    lead_time: float = _p(0.01, "s", 0, 0.1, doc="path evaluated at s + q1' * lead_time (ZOH + motor lag)")
    predict_friction: bool = field(default=True, metadata=dict(doc="the path generator's arrival predictor includes the nominal link-1 damping"))
    calibrate: bool = field(default=True, metadata=dict(doc="the path generator fits link 1's effective damping during the first half of the swing"))
    calibrate_start: float = _p(0.2, "rad/s", 0, doc="record the calibration start once q1' exceeds this")
    calibrate_at: float = _p(0.35, "", 0, 1, doc="fit the effective damping at s = -calibrate_at * s_f")
    pump_gain: float = _p(1.0, "", 0.5, 3, doc="RTS gain lam in the first half (energy pumping for inclines)")
    lab_gain: float = _p(1.5, "", 0, 5, doc="gain of the lab firmware path")

    def resolved(self, incline_deg: float, controller: "ControllerParams") -> "PathParams":
        """The path block with ``mode = "auto"`` made concrete:
        :data:`AUTO_PATH_MODE` (``incline_deg`` does not enter)."""
        if self.mode != "auto":
            return self
        plan = controller.preset == "plan" and not controller.plugin
        return replace(self, mode="plan" if plan else "adaptive")

    def _check(self):
        if self.mode not in PATH_MODES:
            raise ParameterError(f"path.mode = '{self.mode}' is unknown; allowed: "
                                 + ", ".join(PATH_MODES))
