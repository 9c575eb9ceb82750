"""One typed source of truth for every BPLIR parameter.

Every block is a frozen dataclass.  Each field carries its unit and allowed
range in ``field(metadata=...)``; ``__post_init__`` validates the block and
raises :class:`ParameterError` with a one-line message naming the field and
the allowed range.  Presets are looked up by name (:func:`preset`) and whole
parameter sets are read from / written to TOML (:func:`load_toml`,
:func:`to_toml`).

Nominal versus true: ``BplirParams.plant`` and ``BplirParams.friction`` are the
*nominal* model that controllers and estimators are built from.  The simulated
robot uses ``true_plant`` / ``true_friction`` when given (otherwise the
nominal blocks).  Controllers never receive the ``true_*`` blocks.

Dissertation sources: Table 4.3 (plant, friction), Table 4.2 and
(4.12)-(4.14) (motor), Table 5.1 and (5.36)-(5.40) (IMU, estimator), chapter
6 (controller), chapter 7 (path), docs/concepts.md (scenario and success criteria).
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

INF = math.inf


class ParameterError(ValueError):
    """A parameter, preset or parameter file is invalid (one-line message)."""


def _p(default, unit: str, lo: float = -INF, hi: float = INF, *, lo_open=False,
       hi_open=False, doc: str = ""):
    """A numeric field with unit and allowed range ``[lo, hi]`` (or open)."""
    return field(default=default, metadata=dict(unit=unit, lo=lo, hi=hi,
                                                lo_open=lo_open, hi_open=hi_open,
                                                doc=doc))


def _positive(default, unit: str, *, doc: str = ""):
    """A numeric field that must be > 0 (a length, mass, period, ...)."""
    return _p(default, unit, 0, lo_open=True, doc=doc)


#: the longest link or sensor distance a two-link brachiator can have (m)
MAX_LENGTH = 10.0


def _length(default, *, doc: str = ""):
    """A length of the robot (m) in (0, MAX_LENGTH]."""
    return _p(default, "m", 0, MAX_LENGTH, lo_open=True, doc=doc)


def _fraction(default, *, doc: str = ""):
    """A dimensionless field in (0, 1] (an efficiency, a share)."""
    return _p(default, "", 0, 1, lo_open=True, doc=doc)


def _is_plugin(spec) -> bool:
    """``spec`` has the form ``module:factory`` (the module may be a path)."""
    if not isinstance(spec, str) or ":" not in spec:
        return False
    module, factory = spec.rsplit(":", 1)
    return bool(module) and factory.isidentifier()


def plugin_name(spec: str) -> str:
    """A plug-in's own name from its ``module:factory`` spec: a file's stem
    (``path/to/my_controller.py:make`` -> ``my_controller:make``), a module
    as it is; a preset name unchanged."""
    if not _is_plugin(spec):
        return spec
    module, factory = spec.rsplit(":", 1)
    if module.endswith(".py") or "/" in module or "\\" in module:
        module = Path(module).stem
    return f"{module}:{factory}"


def _range_text(md) -> str:
    lo, hi = md["lo"], md["hi"]
    left = "(" if md["lo_open"] or lo == -INF else "["
    right = ")" if md["hi_open"] or hi == INF else "]"
    unit = f" {md['unit']}" if md["unit"] else ""
    return f"{left}{lo:g}, {hi:g}{right}{unit}"


def _validate_block(block, name: str) -> None:
    for f in fields(block):
        md = f.metadata
        value = getattr(block, f.name)
        if "lo" not in md:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParameterError(
                f"{name}.{f.name} = {value!r} is not a number; allowed range "
                f"{_range_text(md)}")
        if not math.isfinite(value):
            raise ParameterError(
                f"{name}.{f.name} = {value} is not finite; allowed range "
                f"{_range_text(md)}")
        lo, hi = md["lo"], md["hi"]
        bad_lo = value <= lo if md["lo_open"] else value < lo
        bad_hi = value >= hi if md["hi_open"] else value > hi
        if bad_lo or bad_hi:
            raise ParameterError(
                f"{name}.{f.name} = {value:g} is out of range; allowed "
                f"{_range_text(md)}")


class _Block:
    """Mixin: validation on construction, conversion to/from dicts."""

    _name = "block"

    def __post_init__(self):
        _validate_block(self, self._name)
        self._check()

    def _check(self) -> None:  # cross-field checks
        pass

    def as_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, data: dict[str, Any], base=None):
        base = base if base is not None else cls()
        known = {f.name for f in fields(cls)}
        for key in data:
            if key not in known:
                raise ParameterError(
                    f"unknown parameter '{cls._name}.{key}'; allowed: "
                    + ", ".join(sorted(known)))
        values = {}
        for f in fields(cls):
            if f.name in data:
                v = data[f.name]
                if isinstance(getattr(base, f.name), tuple):
                    if not isinstance(v, list):
                        raise ParameterError(f"{cls._name}.{f.name} = {v!r} must be a list")
                    v = tuple(v)
                if "lo" in f.metadata and isinstance(v, int) and not isinstance(v, bool):
                    try:
                        v = float(v)
                    except OverflowError:   # a TOML integer of hundreds of digits
                        raise ParameterError(
                            f"{cls._name}.{f.name} = {str(v)[:12]}... ({len(str(v))} digits) "
                            f"is not a finite number; allowed range "
                            f"{_range_text(f.metadata)}") from None
                expected = type(getattr(base, f.name))
                if expected is bool and not isinstance(v, bool):
                    raise ParameterError(
                        f"{cls._name}.{f.name} = {v!r} must be true or false")
                if expected is str and not isinstance(v, str):
                    raise ParameterError(
                        f"{cls._name}.{f.name} = {v!r} must be a string")
                values[f.name] = v
        return replace(base, **values)

    def describe(self) -> list[tuple[str, Any, str, str]]:
        """(name, value, unit, doc) rows for documentation and reports."""
        return [(f.name, getattr(self, f.name), f.metadata.get("unit", ""),
                 f.metadata.get("doc", "")) for f in fields(self)]


# ---------------------------------------------------------------- plant
@dataclass(frozen=True)
class PlantParams(_Block):
    """Rigid-body parameters of the two-link acrobot (Table 4.3)."""

    _name = "plant"
    m1: float = _positive(3.2287, "kg", doc="mass of link 1 (gripper-side link)")
    m2: float = _positive(1.5155, "kg", doc="mass of link 2 (free link)")
    l1: float = _length(0.9091, doc="length of link 1 (pivot to elbow)")
    l2: float = _length(1.2451, doc="length of link 2 (elbow to free gripper)")
    lc1: float = _p(0.2167, "m", 0, MAX_LENGTH, doc="pivot to centre of mass of link 1")
    lc2: float = _p(0.5459, "m", 0, MAX_LENGTH, doc="elbow to centre of mass of link 2")
    I1: float = _positive(0.1539, "kg m^2", doc="inertia of link 1 about its CoM")
    I2: float = _positive(0.2191, "kg m^2", doc="inertia of link 2 about its CoM")
    g: float = _p(9.81, "m/s^2", 0, 30, lo_open=True, doc="gravitational acceleration")

    def _check(self):
        if self.lc1 > self.l1:
            raise ParameterError(
                f"plant.lc1 = {self.lc1:g} m exceeds plant.l1 = {self.l1:g} m; "
                f"allowed [0, l1]")
        if self.lc2 > self.l2:
            raise ParameterError(
                f"plant.lc2 = {self.lc2:g} m exceeds plant.l2 = {self.l2:g} m; "
                f"allowed [0, l2]")


# ---------------------------------------------------------------- friction
@dataclass(frozen=True)
class FrictionParams(_Block):
    """Joint friction (4.10)/(4.11) per joint: viscous, Coulomb, drag.

    The drag term is ``0.5*rho_air*cd*area_i*qd*|qd|`` (a lumped coefficient;
    the dissertation gives no values, so the areas default to zero: the
    Table 4.3 calibration already lumps drag into fv and fc).
    """

    _name = "friction"
    fv1: float = _p(0.1706, "N m s/rad", 0, doc="viscous friction, joint 1 (gripper)")
    fv2: float = _p(0.0765, "N m s/rad", 0, doc="viscous friction, joint 2 (elbow)")
    fc1: float = _p(0.0124, "N m", 0, doc="Coulomb friction, joint 1")
    fc2: float = _p(0.7681, "N m", 0, doc="Coulomb friction, joint 2")
    b: float = _p(0.01, "rad/s", 0, 10, lo_open=True,
                  doc="arctan smoothing velocity of (4.11)")
    rho_air: float = _p(1.225, "kg/m^3", 0, doc="air density")
    cd: float = _p(1.0, "", 0, doc="drag coefficient")
    area1: float = _p(0.0, "m^2 (lumped)", 0, doc="effective drag area, joint 1")
    area2: float = _p(0.0, "m^2 (lumped)", 0, doc="effective drag area, joint 2")
    enabled: bool = field(default=True, metadata=dict(doc="joint friction on (false: a frictionless plant)"))

    def drag_coefficients(self) -> tuple[float, float]:
        """(k1, k2) = 0.5 rho Cd A of each joint (N m s^2/rad^2)."""
        k = 0.5 * self.rho_air * self.cd
        return k * self.area1, k * self.area2

    def scaled(self, viscous: float = 1.0, coulomb: float = 1.0) -> "FrictionParams":
        """Both viscous coefficients times ``viscous``, both Coulomb ones
        times ``coulomb``."""
        return self.with_factors((viscous, viscous, coulomb, coulomb))

    def with_factors(self, factors) -> "FrictionParams":
        """``(fv1, fv2, fc1, fc2)`` each times its factor (a perturbed
        friction, e.g. drawn within +/- 20 % as in 3.3)."""
        k = [float(v) for v in factors]
        return replace(self, fv1=self.fv1 * k[0], fv2=self.fv2 * k[1], fc1=self.fc1 * k[2],
                       fc2=self.fc2 * k[3])


# ---------------------------------------------------------------- motor
@dataclass(frozen=True)
class MotorParams(_Block):
    """Motor, gearbox and ESCON 50/5 driver (Table 4.2, (4.12)-(4.14)).

    ``km`` is the motor torque constant.  Table 4.2 prints 0.634 N m/A, which
    would make 15 A worth 456 N m at the output; the datasheet's own stall
    torque / stall current (3.43 N m / 124 A = 0.02766 N m/A) gives 19.9 N m
    at 15 A (the "theoretical 20 N m") and 0.836 N m at the 0.63 A dead-band
    current (the printed 0.82336 N m of (4.14)), so that value is used.
    """

    _name = "motor"
    km: float = _positive(3.43 / 124.0, "N m/A", doc="motor torque constant")
    gear_ratio: float = _positive(74.0, "", doc="gearbox ratio N")
    eta_g: float = _fraction(0.72, doc="gearbox efficiency")
    eta_m: float = _fraction(0.90, doc="motor efficiency")
    i_peak: float = _positive(15.0, "A", doc="driver peak current")
    t_peak: float = _positive(2.675, "s", doc="time the driver holds peak current")
    i_cont: float = _positive(5.0, "A", doc="driver continuous current")
    tau_current: float = _p(0.005, "s", 0, 0.01, lo_open=True,
                            doc="current-loop time constant (<= 10 ms, 4.4)")
    deadband: float = _p(0.82336, "N m", 0, doc="torque dead-band (4.14)")
    torque_limit: float = _p(20.0, "N m", 0, lo_open=True,
                             doc="torque saturation (20 theoretical, 15 practical)")
    power_rating: float = _positive(220.0, "W", doc="motor power rating")
    driver_period: float = _p(0.01, "s", 0, 1, lo_open=True,
                              doc="update period of the driver's i^2 t interlock")
    supply_voltage: float = _p(30.0, "V", 1, 100,
                               doc="supply voltage (Table 4.2: 30 V as built, 48 V nominal)")
    resistance: float = _positive(48.0 / 124.0, "ohm",
                                  doc="winding resistance (Table 4.2: 48 V / 124 A stall)")
    voltage_fraction: float = _fraction(
        0.98, doc="largest driver output voltage / supply (ESCON 50/5 datasheet: 0.98)")
    envelope: bool = field(default=True, metadata=dict(
        doc="the driver's output voltage limits the current (back-EMF and winding resistance)"))

    @property
    def back_emf_constant(self) -> float:
        """Motor back-EMF constant (V s/rad), equal to ``km`` in SI units."""
        return self.km

    @property
    def max_voltage(self) -> float:
        """Largest voltage the driver puts across the motor (V)."""
        return self.voltage_fraction * self.supply_voltage

    def _check(self):
        if self.i_cont > self.i_peak:
            raise ParameterError(
                f"motor.i_cont = {self.i_cont:g} A exceeds motor.i_peak = "
                f"{self.i_peak:g} A; allowed (0, i_peak]")

    @property
    def torque_per_amp(self) -> float:
        """(4.12): tau = Km N eta_g eta_m i."""
        return self.km * self.gear_ratio * self.eta_g * self.eta_m


# ---------------------------------------------------------------- IMU
@dataclass(frozen=True)
class ImuParams(_Block):
    """Two planar IMUs (Table 5.1).  ``r_i`` is the distance of IMU i from
    the proximal joint of link i (the true mounting position).

    Noise is given per sample at the sampling rate.  Table 5.1 prints
    0.02156 m/s^2 (= 220 ug/sqrt(Hz) at 100 Hz) and 0.0166 rad/s; note that
    0.03 dps/sqrt(Hz) at 100 Hz is 0.0052 rad/s: 0.0166 corresponds to a
    1 kHz bandwidth.  The published (larger) value is the default.
    """

    _name = "imu"
    r1: float = _length(0.5, doc="IMU 1 distance from the gripper joint along link 1")
    r2: float = _length(0.5, doc="IMU 2 distance from the elbow along link 2")
    rate_hz: float = _p(100.0, "Hz", 1, 10000, doc="sampling rate (zero-order hold)")
    accel_sigma: float = _p(0.02156, "m/s^2", 0, doc="accelerometer white noise per sample (5.36)")
    gyro_sigma: float = _p(0.0166, "rad/s", 0, doc="gyro white noise per sample (5.37)")
    gyro_bias1: float = _p(0.0, "rad/s", -1, 1, doc="constant gyro bias, IMU 1")
    gyro_bias2: float = _p(0.0, "rad/s", -1, 1, doc="constant gyro bias, IMU 2")
    gyro_drift: float = _p(0.0, "rad/s/sqrt(s)", 0, 1, doc="gyro bias random-walk density")
    misalign1: float = _p(0.0, "rad", -0.2, 0.2, doc="accelerometer misalignment, IMU 1 (5.38)")
    misalign2: float = _p(0.0, "rad", -0.2, 0.2, doc="accelerometer misalignment, IMU 2")
    accel_scale1: float = _p(0.0, "", -0.2, 0.2, doc="accelerometer scale error, IMU 1")
    accel_scale2: float = _p(0.0, "", -0.2, 0.2, doc="accelerometer scale error, IMU 2")
    gyro_scale1: float = _p(0.0, "", -0.2, 0.2, doc="gyro scale error, IMU 1 (reads (1 + s) omega)")
    gyro_scale2: float = _p(0.0, "", -0.2, 0.2, doc="gyro scale error, IMU 2")
    noise: bool = field(default=True, metadata=dict(doc="add the IMUs' white noise (false: noise-free readings; biases and misalignments stay)"))

    @property
    def period(self) -> float:
        """Sampling period (s)."""
        return 1.0 / self.rate_hz


@dataclass(frozen=True)
class LineSensorParams(_Block):
    """A range sensor on each gripper's jaw looking at the line (a short-range
    laser triangulation or time-of-flight sensor, as line-inspection robots
    carry to find the conductor), sampled with the IMUs: it reads the free
    gripper's distance below the line, with white noise and a constant
    offset (its mounting), while that distance is within ``range``.  The
    estimator fuses it (:mod:`bplir_drake.systems.line_sensor`); 0: no
    sensor, the IMUs alone (the dissertation's robot)."""

    _name = "line_sensor"
    range: float = _p(0.0, "m", 0, 1, doc="largest gripper-to-line distance the sensor reads; 0: no sensor, the IMUs alone (the dissertation's robot)")
    sigma: float = _p(0.001, "m", 0, 0.05, doc="white noise per sample")
    offset: float = _p(0.0, "m", -0.02, 0.02, doc="constant reading error (mounting): the sensor reads the distance plus this")
    filter_sigma: float = _positive(0.0015, "m", doc="the noise the estimator assumes for a reading (its R)")


def sigma_from_density(density: float, rate_hz: float) -> float:
    """Per-sample standard deviation of white noise with the given density."""
    return density * math.sqrt(rate_hz)


# ---------------------------------------------------------------- estimator
@dataclass(frozen=True)
class EstimatorParams(_Block):
    """Kinematic EKF (chapter 5): geometry and noise only.

    No mass, inertia or friction may appear here (the filter is kinematic).

    Two tunings, both here.  The defaults are the dissertation's (5.39)-
    (5.40) with explicit Euler (5.3): robust from an unknown initial pose
    (1 rad errors converge in ~0.25 s).  Inside the control loop of a swing
    they lag (~30 ms in the rates) and the rectangle-rule angle update drifts
    during the fast elbow motion, which destabilises the loop; a swing starts
    from its known pose on the line, so :meth:`for_loop` applies the
    ``loop_*`` tuning (gyro-trusting rates, second-order angle step): about
    7x smaller angle errors, but it can lock onto a wrong solution from a
    1 rad initial error, so it is only used from a known start.
    """

    _name = "estimator"

    def _check(self):
        if self.r1 > self.l1:
            raise ParameterError(f"estimator.r1 = {self.r1:g} m exceeds estimator.l1 = "
                                 f"{self.l1:g} m; allowed (0, l1]")
        if not isinstance(self.plugin, str) or (self.plugin and not _is_plugin(self.plugin)):
            raise ParameterError(
                f"estimator.plugin = {self.plugin!r} must be 'module:factory' (a module "
                "name or a .py file, a colon, a function returning a Drake system)")
        for name in ("integration", "loop_integration"):
            if getattr(self, name) not in ("euler", "trapezoid", "heun"):
                raise ParameterError(f"estimator.{name} = '{getattr(self, name)}' is unknown; "
                                     "allowed: euler, trapezoid, heun")

    r1: float = _length(0.5, doc="IMU 1 distance from joint 1 (filter geometry)")
    r2: float = _length(0.5, doc="IMU 2 distance from the elbow")
    l1: float = _length(0.9091, doc="link 1 length (filter geometry)")
    g: float = _p(9.81, "m/s^2", 0, 30, lo_open=True, doc="gravity used by the filter")
    period: float = _p(0.01, "s", 0, 1, lo_open=True, doc="filter period (100 Hz)")
    accel_process_sigma: float = _positive(0.427, "m/s^2", doc="(5.39) process noise on the accelerometer inputs")
    gyro_meas_sigma: float = _positive(0.02, "rad/s", doc="(5.40) gyro measurement noise")
    accel_meas_sigma: float = _positive(0.427, "m/s^2", doc="accelerometer measurement noise (5.39)")
    integration: str = field(default="euler", metadata=dict(doc="prediction step of the offline filter: euler (5.3), trapezoid or heun", allowed="euler, trapezoid, heun"))
    loop_accel_process_sigma: float = _positive(0.2, "m/s^2", doc="in-loop tuning: process noise on the accelerometer inputs (with Heun's step)")
    loop_gyro_meas_sigma: float = _positive(0.0166, "rad/s", doc="in-loop tuning: gyro noise (Table 5.1)")
    loop_accel_meas_sigma: float = _positive(0.1, "m/s^2", doc="in-loop tuning: accelerometer measurement noise")
    # Heun's step with the accelerations at both ends of the period (was
    # "trapezoid"): its smaller discretisation error lets the filter trust the
    # accelerometers' gravity 10x more (process noise 0.2 instead of 2.0 m/s^2)
    loop_integration: str = field(default="heun", metadata=dict(doc="in-loop tuning: prediction step of the swing's filter (heun: the accelerations at both ends of the period)", allowed="euler, trapezoid, heun"))
    p0_angle: float = _positive(1.0, "rad", doc="initial angle standard deviation")
    p0_rate: float = _positive(0.5, "rad/s", doc="initial rate standard deviation")
    start_angle_sigma: float = _positive(0.02, "rad", doc="initial angle sd when a swing starts at rest on the line, about the pose the robot believes it is in")
    start_rate_sigma: float = _positive(0.05, "rad/s", doc="initial rate sd at a swing start (at rest)")
    start_bias_sigma: float = _positive(0.002, "rad/s", doc="gyro-bias sd at a swing start (calibrated while held on the line)")
    standstill_samples: float = _p(500, "samples", 0, 100000, doc="IMU samples averaged at rest on the line before a swing to calibrate gyro biases and misalignments (0: none, the dissertation's filter; 500 = 5 s)")
    tuned_gyro_noise: float = _positive(0.0166, "rad/s", doc="gyro noise per sample the in-loop tuning assumes (Table 5.1); a standstill calibration measuring more widens R by the ratio")
    tuned_accel_noise: float = _positive(0.02156, "m/s^2", doc="accelerometer noise per sample the in-loop tuning assumes (Table 5.1); a standstill calibration measuring more widens R by the ratio")
    noise_tolerance: float = _p(1.2, "", 1, 100, doc="R is widened only when the measured noise exceeds the tuned one by more than this factor (500 samples measure it within 6 %)")
    inflate_nis: float = _p(0.0, "", 0, 1000, doc="covariance inflation: a tick whose normalised innovation squared exceeds this multiple of its expectation inflates the predicted covariance by the excess (0: never)")
    loop_estimate_misalignment: bool = field(default=True, metadata=dict(doc="in-loop tuning: the swing's filter goes on estimating each accelerometer's misalignment in flight, from the standstill calibration's value"))
    misalign_max_noise: float = _p(3.0, "", 1, 100, doc="misalignment states are held at the standstill calibration's values when it measures the IMUs noisier than this many times the tuned noise (their in-flight estimate then wanders)")
    loop_inflate_nis: float = _p(3.0, "", 0, 1000, doc="in-loop tuning: inflate_nis of the swing's filter (lets torque noise and heavy sensor noise move the estimate)")
    estimate_bias: bool = field(default=True, metadata=dict(doc="estimate a constant gyro bias per IMU (two extra states)"))
    bias_sigma0: float = _positive(0.05, "rad/s", doc="initial gyro-bias standard deviation")
    bias_walk: float = _positive(1e-3, "rad/s/sqrt(s)", doc="gyro-bias random walk")
    estimate_misalignment: bool = field(default=False, metadata=dict(doc="self-calibration: estimate each accelerometer's misalignment"))
    misalign_sigma0: float = _positive(0.05, "rad", doc="initial accelerometer-misalignment standard deviation (self-calibration states)")
    misalign_walk: float = _positive(1e-4, "rad/sqrt(s)", doc="accelerometer-misalignment random walk")
    estimate_gyro_scale: bool = field(default=False, metadata=dict(doc="self-calibration: estimate each gyro's scale error"))
    gyro_scale_sigma0: float = _positive(0.02, "1", doc="initial gyro scale-error standard deviation (self-calibration states)")
    gyro_scale_walk: float = _positive(1e-5, "1/sqrt(s)", doc="gyro scale-error random walk")
    estimate_imu_position: bool = field(default=False, metadata=dict(doc="self-calibration: estimate each IMU's distance along its link"))
    calibrate_after: float = _p(0.0, "s", 0, 3600, doc="bias and self-calibration states are held (Schmidt consider states) this long after the first sample while the angles converge (0: never held)")
    imu_position_sigma0: float = _positive(0.02, "m", doc="initial standard deviation of each IMU's distance along its link (self-calibration states; they start at r1, r2)")
    imu_position_walk: float = _positive(1e-5, "m/sqrt(s)", doc="IMU-distance random walk")
    datasheet_process_sigma: float = _positive(0.05, "m/s^2", doc="process noise on the accelerometer inputs when R is the IMUs' own noise (with_sensor_noise; NIS-consistent on the estimation benchmark)")
    plugin: str = field(default="", metadata=dict(doc="module:factory of your own estimator, used in a swing instead of the EKF ('' : the EKF)", allowed="module:factory or ''"))

    def self_calibrating(self) -> "EstimatorParams":
        """The same filter with the self-calibration states (accelerometer
        misalignment, gyro scale and IMU distance beside the gyro biases),
        Heun's second-order step (explicit Euler lags the angles by half a
        period, 5 ms; a step that takes gravity at the period's start
        biases the calibration states, see
        :func:`bplir_drake.systems.ekf.discrete_f`) and those states held
        for the first 2 s, while the angles converge from an unknown start
        (``bplir estimate --self-calibrate``; issue 20)."""
        return replace(self, estimate_bias=True, estimate_misalignment=True,
                       estimate_gyro_scale=True, estimate_imu_position=True,
                       integration="heun", calibrate_after=max(self.calibrate_after, 2.0))

    def with_sensor_noise(self, imu: "ImuParams") -> "EstimatorParams":
        """The same filter tuned to the IMUs' own noise: R from ``imu``'s
        per-sample gyro and accelerometer noise (Table 5.1 by default) and
        ``datasheet_process_sigma`` on the accelerometer inputs, instead of
        the dissertation's (5.39)-(5.40), which assume accelerometers 20x
        noisier than Table 5.1 (mean NIS about 1.1 where 4 is consistent)."""
        return replace(self, gyro_meas_sigma=imu.gyro_sigma, accel_meas_sigma=imu.accel_sigma,
                       accel_process_sigma=self.datasheet_process_sigma)

    def with_measured_noise(self, gyro: float, accel: float) -> "EstimatorParams":
        """The same filter with its measurement noise widened to the noise
        a standstill calibration measured (per sample: ``gyro`` rad/s,
        ``accel`` m/s^2), by its ratio to ``tuned_*_noise`` where that is
        above ``noise_tolerance`` (never narrowed; 0: not measured,
        unchanged)."""
        def widen(ratio):
            return ratio if ratio > self.noise_tolerance else 1.0

        kg = widen(gyro / self.tuned_gyro_noise)
        ka = widen(accel / self.tuned_accel_noise)
        if kg == 1.0 and ka == 1.0:
            return self
        return replace(self, gyro_meas_sigma=self.gyro_meas_sigma * kg,
                       accel_meas_sigma=self.accel_meas_sigma * ka)

    def for_loop(self) -> "EstimatorParams":
        """The same filter with the in-loop tuning (used by the swing)."""
        return replace(self, accel_process_sigma=self.loop_accel_process_sigma,
                       gyro_meas_sigma=self.loop_gyro_meas_sigma,
                       accel_meas_sigma=self.loop_accel_meas_sigma,
                       integration=self.loop_integration, inflate_nis=self.loop_inflate_nis,
                       estimate_misalignment=(self.estimate_misalignment
                                              or self.loop_estimate_misalignment))


#: the in-loop filter tuning with the trapezoid step (``EstimatorParams``
#: fields), which needs 10x the process noise of Heun's step, and no
#: in-flight misalignment estimate; the adaptive path's delay compensation
#: and latch were built with it
TRAPEZOID_LOOP_TUNING = {"loop_integration": "trapezoid", "loop_accel_process_sigma": 2.0,
                         "loop_accel_meas_sigma": 0.05, "loop_estimate_misalignment": False}


#: the shooting landing's aim and hold of the robot without the jaw's line
#: sensor (the defaults; :meth:`BplirParams.imu_only`)
IMU_ONLY_TUNING = {"shoot_height": -0.015, "shoot_min_time": 0.04, "shoot_lift_min_time": 0.0}

#: the jaw's line sensor as a hardware option: its range, and the landing's
#: aim and hold with it (:meth:`BplirParams.with_hardware`)
LINE_SENSOR_OPTION = {"range": 0.2, "shoot_height": -0.018, "shoot_min_time": 0.03,
                      "shoot_lift_min_time": 0.05}

#: named hardware options on top of a preset (:meth:`BplirParams.with_hardware`)
HARDWARE_OPTIONS = {
    "line-sensor": "a range sensor in each gripper's jaw reading the line within 0.2 m",
    "48v": "a 48 V supply (the motor's datasheet rating) instead of the 30 V the robot has",
}


# ---------------------------------------------------------------- controller
CONTROLLER_PRESETS = ("qft", "dissertation", "lab")

#: Outer-loop designs as continuous-time transfer functions (numerator,
#: denominator coefficients, highest power first) of ``K(s)`` acting on
#: ``e = F(r) - y`` and of the prefilter ``F(s)``.  ``dissertation`` is
#: (6.23)-(6.24) as published (for the measured family (4.16), whose sign
#: is negative); ``lab`` is the firmware's proportional law (sign corrected
#: for the simulated plant q2'' = v, see docs/errata.md); ``qft`` is designed for
#: the plant family of the simulated CPFL loop by :mod:`bplir_drake.analysis.control.qft`
#: (``bplir qft --family diagram`` re-verifies it).
OUTER_LOOP_DESIGNS = {
    "dissertation": {"k_num": (-216.0,), "k_den": (1.0,),
                     "f_num": (10.61,), "f_den": (1.0, 8.616)},
    "lab": {"k_num": (95.0,), "k_den": (1.0,), "f_num": (1.0,), "f_den": (1.0,)},
    # design_qft on diagram_family(seed=0, 60 plants); verified on seed 1
    "qft": {"k_num": (18.25195, 159.3015, 46.14857), "k_den": (0.004000074, 1.0, 0.0),
            "f_num": (860.6985,), "f_den": (1.0, 117.9063, 868.9110)},
}


@dataclass(frozen=True)
class ControllerParams(_Block):
    """CPFL inner loop + outer loop (chapter 6).  ``preset`` picks the outer
    loop design (see :data:`OUTER_LOOP_DESIGNS`); non-empty ``k_num`` ...
    ``f_den`` override it."""

    _name = "controller"
    preset: str = field(default="qft", metadata=dict(doc="the controller preset: qft (plan tracking with its landing), dissertation (CPFL + QFT + path generator), lab (the lab firmware)", allowed="qft, dissertation, lab"))
    period: float = _p(0.01, "s", 0, 1, lo_open=True, doc="controller sample time Ts")
    torque_limit: float = _positive(20.0, "N m", doc="saturation in the controller")
    aw_gain: float = _p(100.0, "", 0, doc="anti-windup gain X >> 1 (Fig. 6.7); 0 disables")
    delay_samples: float = _p(0.0, "samples", 0, 1, doc="command applied this many samples late (0 or 1)")
    torque_quantum: float = _p(0.0, "N m", 0, 5, doc="truncate the torque to multiples of this (firmware: 1)")
    compute_latency: float = _p(3e-4, "s", 0, 0.01, doc="time from the IMU sample to the command reaching the driver (< period)")
    delay_compensation: float = _p(0.0, "s", 0, 0.1, doc="actuation delay the CPFL controller assumes (whole periods): it acts on the state predicted this far ahead (0: none)")
    friction_compensation: bool = field(default=False, metadata=dict(doc="CPFL includes the nominal friction in its feedback linearisation"))
    sign_correct: bool = field(default=True, metadata=dict(doc="negate a K of negative gain (the published K = -216 matches the measured plant's sign, see errata)"))
    plugin: str = field(default="", metadata=dict(doc="module:factory of your own controller ('' : the preset's)", allowed="module:factory or ''"))
    k_num: tuple = field(default=(), metadata=dict(doc="outer-loop K numerator, highest power first (empty: the preset's design)"))
    k_den: tuple = field(default=(), metadata=dict(doc="outer-loop K denominator, highest power first"))
    f_num: tuple = field(default=(), metadata=dict(doc="prefilter F numerator, highest power first"))
    f_den: tuple = field(default=(), metadata=dict(doc="prefilter F denominator, highest power first"))

    def _check(self):
        if not isinstance(self.plugin, str) or (self.plugin and not _is_plugin(self.plugin)):
            raise ParameterError(
                f"controller.plugin = {self.plugin!r} must be 'module:factory' (a module "
                "name or a .py file, a colon, a function returning a Drake system)")
        if self.preset not in CONTROLLER_PRESETS:
            raise ParameterError(
                f"controller.preset = '{self.preset}' is unknown; allowed: "
                + ", ".join(CONTROLLER_PRESETS))
        if self.compute_latency >= self.period:
            raise ParameterError(
                f"controller.compute_latency = {self.compute_latency:g} s must be shorter "
                f"than controller.period = {self.period:g} s; allowed [0, period)")
        if self.delay_samples not in (0.0, 1.0):
            raise ParameterError(
                f"controller.delay_samples = {self.delay_samples:g} must be 0 or 1")
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
            import numpy as _np

            poles = _np.roots(f_den)
            if _np.any(poles.real >= 0):
                raise ParameterError(
                    f"controller prefilter F has poles {poles.tolist()} not in the open left "
                    "half plane; an unstable prefilter is not allowed")

    @classmethod
    def preset_named(cls, name: str, **overrides) -> "ControllerParams":
        """Controller parameters of a named preset (with its firmware quirks)."""
        if name not in CONTROLLER_PRESETS:
            raise ParameterError(
                f"unknown controller preset '{name}'; allowed: " + ", ".join(CONTROLLER_PRESETS)
                + ", or module:factory (your own controller)")
        extra = {"lab": dict(aw_gain=0.0, delay_samples=1.0, torque_quantum=1.0)}.get(name, {})
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
PLAN_INDEXING = ("time", "state")
LANDING_LAWS = ("aim", "shoot", "auto")


@dataclass(frozen=True)
class PathParams(_Block):
    """Online path generator (chapter 7).  ``mode``: ``auto`` (the default:
    ``plan`` on an inclined line, ``adaptive`` on a horizontal one, for the
    project's ``qft`` controller; the ``dissertation`` preset and plug-in
    controllers keep ``adaptive``; see :meth:`resolved`), ``adaptive`` (RTS +
    blend to line seeking with the adaptive blend end), ``rts`` (the RTS path
    with the blend (7.20)-(7.21) at its printed end, no adaptation),
    ``lab`` (the firmware's ``1.5 q1 q2f/q1f``) or ``plan`` (no path: a
    time-varying LQR tracks a trajectory-optimised swing, indexed by the
    clock (``plan_indexing = "time"``) or, clock-free, by the phase nearest
    to the estimated state (``"state"``); see
    :mod:`bplir_drake.systems.plan_tracker`)."""

    _name = "path"
    mode: str = field(default="auto", metadata=dict(doc="how the swing is steered: auto (plan for the qft preset, adaptive otherwise), plan, adaptive, rts, lab", allowed="auto, plan, adaptive, rts, lab"))
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
    plan_end_depth: float = _p(0.015, "m", 0, 0.1, doc="mode 'plan': the planned swing comes to rest this far below the line, inside the capture band, so the band is entered slowly")
    plan_voltage_share: float = _fraction(0.9, doc="mode 'plan': share of the driver's largest voltage the plan may use at its knots (the rest is the feedback's headroom)")
    plan_spacing_step: float = _p(0.01, "m", 0, 0.1, doc="mode 'plan': plans are made for the measured grip spacing rounded to this step, so a study drawing the spacing solves few plans (0: exact)")
    plan_warm_spacing: float = _p(1.2, "m", 0, 3, doc="mode 'plan': a plan for another spacing is also solved from this spacing's plan and the cheaper one kept (0: straight-line guesses only)")
    plan_indexing: str = field(default="time", metadata=dict(doc="mode 'plan': time (the plan read by the clock) or state (the plan phase nearest the estimate: no clock)", allowed="time, state"))
    # mode 'plan': the terminal reach (systems/plan_tracker.py), off by default
    reach_speed: float = _p(0.0, "m/s", 0, 2, doc="mode 'plan': the terminal reach's speed toward its aim (0: no reach; it lands on the back swing, short of the grip)")
    reach_depth: float = _p(0.12, "m", 0, 0.5, doc="mode 'plan': the reach takes over once the gripper is this close to the line in the plan's second half (or at the plan's end)")
    reach_lift: float = _p(-0.01, "m", -0.1, 0.1, doc="mode 'plan': the reach aims the gripper this far from the line (negative: below, inside the capture band)")
    reach_brake: float = _positive(1.25, "m/s^2", doc="mode 'plan': the reach's speed profile toward its aim, sqrt(reach_speed^2 + 2 reach_brake |distance|)")
    reach_tangent: float = _p(0.25, "m/s", 0, 10, doc="mode 'plan': while the gripper slides along the line faster than this the reach holds it reach_hold from the line (0: never)")
    reach_hold: float = _p(-0.05, "m", -0.2, 0, doc="mode 'plan': see reach_tangent")
    reach_rate_gain: float = _positive(30.0, "1/s", doc="mode 'plan': the reach's speed error to acceleration gain")
    # mode 'plan': the apex landing (systems/plan_tracker.py, issue 17)
    landing_lead: float = _p(0.025, "m s/rad", 0, 1, doc="mode 'plan': the aim law aims landing_margin + landing_lead q1' below the line, so the gripper meets the band as link 1 stops (0: no aim law)")
    landing_margin: float = _p(0.01, "m", 0, 0.1, doc="mode 'plan': the landing aims the gripper this far below the line when link 1 stops (inside the capture band)")
    landing_depth: float = _p(0.12, "m", 0, 0.5, doc="mode 'plan': the aim law takes over once the gripper is this close to the line in the plan's last forward swing of link 1")
    landing_take_rate: float = _p(1.2, "rad/s", 0, 10, doc="mode 'plan': ... or once link 1 slows below this rate while decelerating")
    landing_gain: float = _positive(10.0, "1/s", doc="mode 'plan': the landing's height error to rate gain")
    landing_rate_gain: float = _positive(30.0, "1/s", doc="mode 'plan': the landing's rate error to acceleration gain")
    landing_min_decel: float = _positive(1.0, "rad/s^2", doc="mode 'plan': link 1 counts as decelerating above this (nominal model, elbow held)")
    landing_law: str = field(default="auto", metadata=dict(doc="plan tracking's terminal law: auto (shoot where link 1 carries the gripper to the line, aim where the elbow lifts it), shoot, aim", allowed="auto, shoot, aim"))
    landing_bias: float = _p(0.0, "m", -0.02, 0.02, doc="how far the robot's estimate of the gripper's height ran above the truth at earlier landings; both landing laws aim this much higher")
    shoot_height: float = _p(-0.015, "m", -0.02, 0, doc="landing_law 'shoot': the gripper's aimed distance to the line when link 1 stops (negative: inside the capture band)")
    shoot_depth: float = _p(0.3, "m", 0, 1, doc="landing_law 'shoot': it takes over once the gripper is this close to the line in the plan's last forward swing of link 1")
    shoot_min_time: float = _p(0.04, "s", 0.02, 0.5, doc="landing_law 'shoot': with less time to link 1's stop, or link 1 slower than shoot_min_rate, the stop time is held at this")
    shoot_min_rate: float = _p(0.02, "rad/s", 0, 5, doc="landing_law 'shoot': with link 1 slower than this the shot's stop time is held at shoot_min_time")
    shoot_lift_min_time: float = _p(0.0, "s", 0, 0.5, doc="landing_law 'auto': shoot_min_time where the plan lifts the gripper with the elbow (downhill); 0: the aim law there")
    shoot_lift_height: float = _p(-0.019, "m", -0.02, 0, doc="landing_law 'auto': shoot_height where the plan lifts the gripper with the elbow (see shoot_lift_min_time)")
    shoot_hold_depth: float = _p(0.03, "m", 0, 1, doc="landing_law 'shoot': the stop time is held at shoot_min_time only within this of the aimed height")
    shoot_give_up_rate: float = _p(0.1, "rad/s", 0, 5, doc="landing_law 'shoot': once link 1 swings back faster than this with the gripper below its aim, the shot brakes the elbow and gives up")
    shoot_link1_share: float = _p(0.5, "", 0, 1, doc="landing_law 'auto': the shot where link 1 makes at least this share of the planned gripper's rise rate near the line, else the lift rule")
    plan_delay_compensation: float = _p(0.01, "s", 0, 0.1, doc="mode 'plan': actuation delay the tracker assumes until it has identified one (whole periods; the lab firmware's 10 ms)")
    plan_delay_probe: float = _p(10.0, "N m", 0, 20, doc="mode 'plan': amplitude of the delay probe, two opposite doublets on the first eight commands whose gyro echo identifies the delay (0: none)")
    plan_delay_max: float = _p(0.03, "s", 0.01, 0.1, doc="mode 'plan' with plan_delay_probe: the longest actuation delay the identification considers (whole periods)")
    plan_delay_window: float = _p(12, "ticks", 8, 50, doc="mode 'plan' with plan_delay_probe: the ticks of gyro samples the identification fits (12: 120 ms from the release)")
    plan_delay_min_ratio: float = _p(1.25, "", 1, 100, doc="mode 'plan': the identified delay is used only if the runner-up candidate fits the gyros this many times worse")

    def resolved(self, incline_deg: float, controller: "ControllerParams") -> "PathParams":
        """The path block with ``mode = "auto"`` made concrete: ``plan`` (plan
        tracking with the apex landing) for the ``qft`` preset without a
        plug-in on every line, else ``adaptive`` (the dissertation's path
        generator).  The adaptive path fails the nominal swing on a 5 deg
        line (it cannot pump or shed the energy; the plan can), and on the
        horizontal line plan tracking is the more robust of the two as well
        (realistic study: 93.1 % of 1000 held-out swings, root seed 2,
        against 20 of 100 for the adaptive path on root seed 0; README)."""
        if self.mode != "auto":
            return self
        plan = controller.preset == "qft" and not controller.plugin
        return replace(self, mode="plan" if plan else "adaptive")

    def _check(self):
        if self.mode not in PATH_MODES:
            raise ParameterError(f"path.mode = '{self.mode}' is unknown; allowed: "
                                 + ", ".join(PATH_MODES))
        if self.plan_indexing not in PLAN_INDEXING:
            raise ParameterError(f"path.plan_indexing = '{self.plan_indexing}' is unknown; "
                                 "allowed: " + ", ".join(PLAN_INDEXING))
        if self.landing_law not in LANDING_LAWS:
            raise ParameterError(f"path.landing_law = '{self.landing_law}' is unknown; "
                                 "allowed: " + ", ".join(LANDING_LAWS))
        if 0.0 < self.shoot_lift_min_time < 0.02:
            raise ParameterError(f"path.shoot_lift_min_time = {self.shoot_lift_min_time:g} s is "
                                 "out of range; allowed 0 (the aim law) or [0.02, 0.5] s")
        if self.plan_delay_window != round(self.plan_delay_window):
            raise ParameterError(f"path.plan_delay_window = {self.plan_delay_window:g} ticks "
                                 "is not a whole number; allowed: 8 .. 50")
        if self.landing_lead > 0 and self.reach_speed > 0:
            raise ParameterError(f"path.landing_lead = {self.landing_lead:g} m s/rad and "
                                 f"path.reach_speed = {self.reach_speed:g} m/s are both set; "
                                 "allowed: one terminal law (set the other to 0)")


# ---------------------------------------------------------------- scenario
@dataclass(frozen=True)
class ScenarioParams(_Block):
    """One swing: geometry of the line, thresholds of success, noise seeds."""

    _name = "scenario"
    grip_spacing: float = _positive(1.2, "m", doc="distance D between the grippers on the line")
    incline_deg: float = _p(0.0, "deg", -90, 90, lo_open=True, hi_open=True,
                            doc="line incline (positive: rising in the direction of travel)")
    max_time: float = _p(3.0, "s", 0, 60, lo_open=True, doc="timeout of one swing")
    capture_distance: float = _positive(0.02, "m", doc="gripper-to-line distance that counts as arrival")
    capture_speed: float = _positive(0.5, "m/s", doc="largest gripper speed at arrival (faster is a crash)")
    min_travel_fraction: float = _p(0.8, "", 0, 2, lo_open=True, doc="arrival must be at least this fraction of D along the line")
    friction_uncertainty: float = _p(0.2, "", 0, 0.99, doc="simulated friction drawn within +/- this fraction of nominal")
    wind_torque1: float = _p(0.0, "N m", -20, 20, doc="constant external torque on joint 1 (wind)")
    wind_torque2: float = _p(0.0, "N m", -20, 20, doc="constant external torque on joint 2 (wind)")
    gust_torque: float = _p(0.0, "N m", 0, 20, doc="peak torque of random gusts on each joint")
    gust_rate: float = _p(0.0, "1/s", 0, 100, doc="mean number of gusts per second (Poisson)")
    gust_duration: float = _p(0.1, "s", 0, 1, lo_open=True, doc="duration of one gust")
    torque_noise: float = _p(0.0, "N m", 0, 20, doc="white noise on the applied elbow torque (per controller period)")
    actuation_delay: float = _p(0.0, "s", 0, 0.2, doc="extra delay of the torque command (whole controller periods)")
    seed: int = field(default=0, metadata=dict(doc="seed of the swing's random draws (sensor noise, gusts, the simulated friction)", allowed="[0, 2^32)"))
    use_estimator: bool = field(default=True, metadata=dict(doc="the controller reads the EKF's estimate (false: the true state sampled at its tick)"))
    wall_limit: float = _p(300.0, "s", 0, 86400, lo_open=True, doc="wall-clock time one swing may take before it is stopped as a fault (a hung plug-in); not physics")

    def _check(self):
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ParameterError(
                f"scenario.seed = {self.seed!r} must be a whole number >= 0")


# ---------------------------------------------------------------- traversal
TRAVERSE_SWING_MODES = ("plan", "params")


@dataclass(frozen=True)
class DriveParams(_Block):
    """The wrist-wheel drive that rides the line between obstacles (ours: the
    dissertation names the wheels, chapter 1, but gives no drive data).  A
    trapezoidal speed profile within the speed, acceleration and power limits;
    rolling resistance and the climb are paid at ``efficiency``, nothing is
    recovered downhill."""

    _name = "drive"
    max_speed: float = _p(0.3, "m/s", 0, 2, lo_open=True, doc="riding speed limit")
    max_accel: float = _p(0.2, "m/s^2", 0, 5, lo_open=True, doc="riding acceleration limit")
    rolling_resistance: float = _p(0.02, "", 0, 0.5, doc="rolling resistance coefficient of the wheels on the conductor")
    efficiency: float = _fraction(0.6, doc="electrical-to-mechanical efficiency of the wheel drive")
    power_limit: float = _positive(60.0, "W", doc="largest electrical power of the wheel drive (limits the speed uphill)")
    standby_power: float = _p(5.0, "W", 0, 200, doc="electronics (IMUs, controller, radio) at all times")
    adjust_speed: float = _p(0.05, "m/s", 0, 1, lo_open=True, doc="speed of one wheel setting the grip spacing while the other gripper clamps")


@dataclass(frozen=True)
class TraverseParams(_Block):
    """Crossing a stretch of line (``bplir traverse``): the grip spacing every
    swing is set up at, the margins the planner keeps to obstacles, how swings
    are controlled and when the robot rests for the driver's i^2 t budget."""

    _name = "traverse"
    grip_spacing: float = _p(1.2, "m", 0.5, 2.0, doc="grip spacing every swing is set up at (the swing lands about this far ahead of the holding gripper)")
    clearance: float = _p(0.05, "m", 0, 1, doc="gap kept between a clasped gripper and an obstacle")
    gripper_width: float = _p(0.08, "m", 0, 0.5, doc="length of line a clasped gripper covers")
    landing_tolerance: float = _p(0.08, "m", 0, 1, doc="planned landings lie at least this much further from obstacles (the swing's landing error)")
    swing_mode: str = field(default="plan", metadata=dict(doc="how traversal swings are steered: plan (plan tracking) or the path generator (adaptive)", allowed="plan, adaptive"))
    plan_end_depth: float = _p(0.013, "m", 0, 0.02, doc="swing_mode 'plan': the planned swing comes to rest this far below the line (path.plan_end_depth of every traversal swing)")
    # swing_mode 'plan': the single swing's apex landing and delay compensation
    # (path.landing_*, path.plan_delay_compensation) on every traversal swing
    landing: bool = field(default=True, metadata=dict(doc="traversal swings end with the single swing's landing law"))
    swapped_landing_margin: float = _p(0.0, "m", 0, 0.1, doc="path.landing_margin of the swings holding with gripper 2")
    swapped_landing_law: str = field(default="shoot", metadata=dict(doc="path.landing_law of the swings holding with gripper 2 (the swapped robot)", allowed="auto, shoot, aim"))
    swapped_shoot_min_time: float = _p(0.06, "s", 0.02, 0.5, doc="path.shoot_min_time of the swings holding with gripper 2")
    swapped_shoot_height: float = _p(-0.015, "m", -0.02, 0, doc="path.shoot_height of the swings holding with gripper 2")
    swapped_line_range: float = _p(0.0, "m", 0, 1, doc="the largest line_sensor.range of the swings holding with gripper 2 (0: they estimate with the IMUs alone)")
    swapped_inflate_nis: float = _p(0.0, "", 0, 1000, doc="estimator.loop_inflate_nis of the swings holding with gripper 2 (0: no inflation; its large landing corrections read as model error)")
    landing_learning: float = _p(0.5, "", 0, 1, doc="each swing aims this share of the mean landing height error of the earlier captures holding with the same gripper higher (0: no learning)")
    rest: bool = field(default=True, metadata=dict(doc="rest before a swing until the driver's i^2 t state allows the planned swing"))
    i2t_margin: float = _p(0.2, "", 0, 0.9, doc="share of the driver's i^2 t budget a swing may not use: the planner rests until the planned swing keeps this share free")
    max_incline_deg: float = _p(25.0, "deg", 0, 60, doc="steepest line incline accepted in a line file")

    def _check(self):
        if self.swapped_landing_law not in LANDING_LAWS:
            raise ParameterError(f"traverse.swapped_landing_law = '{self.swapped_landing_law}' "
                                 "is unknown; allowed: " + ", ".join(LANDING_LAWS))
        if self.swing_mode not in TRAVERSE_SWING_MODES:
            raise ParameterError(f"traverse.swing_mode = '{self.swing_mode}' is unknown; "
                                 "allowed: " + ", ".join(TRAVERSE_SWING_MODES))


@dataclass(frozen=True)
class BplirParams:
    """Everything one run needs.  ``plant``/``friction`` are the nominal
    model; ``true_plant``/``true_friction`` (optional) are the simulated robot."""

    plant: PlantParams = field(default_factory=PlantParams)
    friction: FrictionParams = field(default_factory=FrictionParams)
    motor: MotorParams = field(default_factory=MotorParams)
    imu: ImuParams = field(default_factory=ImuParams)
    estimator: EstimatorParams = field(default_factory=EstimatorParams)
    controller: ControllerParams = field(default_factory=ControllerParams)
    path: PathParams = field(default_factory=PathParams)
    scenario: ScenarioParams = field(default_factory=ScenarioParams)
    drive: DriveParams = field(default_factory=DriveParams)
    traverse: TraverseParams = field(default_factory=TraverseParams)
    line_sensor: LineSensorParams = field(default_factory=LineSensorParams)
    true_plant: PlantParams | None = None
    true_friction: FrictionParams | None = None
    preset_name: str = "dissertation"

    def __post_init__(self):
        if (self.imu.r1 > (self.true_plant or self.plant).l1
                or self.imu.r2 > (self.true_plant or self.plant).l2):
            p = self.true_plant or self.plant
            raise ParameterError(
                f"imu.r1 = {self.imu.r1:g} m / imu.r2 = {self.imu.r2:g} m must lie on "
                f"the links; allowed (0, {p.l1:g}] / (0, {p.l2:g}] m")
        if self.estimator.r1 > self.estimator.l1:
            raise ParameterError(
                f"estimator.r1 = {self.estimator.r1:g} m exceeds estimator.l1 = "
                f"{self.estimator.l1:g} m; allowed (0, l1]")

    @property
    def simulated_plant(self) -> PlantParams:
        """The plant the simulator uses: ``true_plant`` or the nominal one."""
        return self.true_plant if self.true_plant is not None else self.plant

    @property
    def simulated_friction(self) -> FrictionParams:
        """The friction the simulator uses: ``true_friction`` or the nominal one."""
        return self.true_friction if self.true_friction is not None else self.friction

    def with_(self, **blocks) -> "BplirParams":
        """A copy with whole blocks replaced."""
        return replace(self, **blocks)

    def resolved(self) -> "BplirParams":
        """A copy whose ``path.mode`` is concrete (:meth:`PathParams.resolved`)."""
        path = self.path.resolved(self.scenario.incline_deg, self.controller)
        return self if path is self.path else replace(self, path=path)

    def with_controller(self, name: str) -> "BplirParams":
        """The controller preset ``name``; the ``lab`` firmware also brings its
        own path (``path.mode = "lab"``), the others keep the path block.  A
        ``module:factory`` name plugs in a user's controller
        (``controller.plugin``; the preset's parameters stay as they are)."""
        if _is_plugin(name):
            return replace(self, controller=replace(self.controller, plugin=name))
        path = replace(self.path, mode="lab") if name == "lab" else self.path
        # the published robots sense the line with their IMUs alone
        sensor = self.line_sensor if name == "qft" else replace(self.line_sensor, range=0.0)
        return replace(self, controller=ControllerParams.preset_named(name), path=path,
                       line_sensor=sensor)

    def imu_only(self) -> "BplirParams":
        """The robot without the jaw's line sensor (``line_sensor.range = 0``:
        the IMUs alone), with the shooting landing's aim of that robot
        (:data:`IMU_ONLY_TUNING`)."""
        return replace(self, line_sensor=replace(self.line_sensor, range=0.0),
                       path=replace(self.path, **IMU_ONLY_TUNING))

    def with_hardware(self, *names: str) -> "BplirParams":
        """The robot with the named hardware options (:data:`HARDWARE_OPTIONS`):
        ``"line-sensor"`` (the jaw's line range sensor and the landing's aim
        with it, :data:`LINE_SENSOR_OPTION`), ``"48v"`` (a 48 V supply)."""
        p = self
        for name in names:
            if name == "line-sensor":
                o = LINE_SENSOR_OPTION
                p = replace(p, line_sensor=replace(p.line_sensor, range=o["range"]),
                            path=replace(p.path, **{k: v for k, v in o.items() if k != "range"}))
            elif name == "48v":
                p = replace(p, motor=replace(p.motor, supply_voltage=48.0))
            else:
                raise ParameterError(f"unknown hardware option '{name}'; allowed: "
                                     + ", ".join(HARDWARE_OPTIONS))
        return p

    def with_estimator(self, spec: str) -> "BplirParams":
        """A user's estimator ``"module:factory"`` in the swing
        (``estimator.plugin``) instead of the EKF; ``""`` restores the EKF."""
        return replace(self, estimator=replace(self.estimator, plugin=spec))


def swapped_plant(p: PlantParams) -> PlantParams:
    """The plant seen from the other gripper: link 2 becomes the holding link
    and link 1 the swinging one.  Lengths, masses and inertias trade places;
    each centre of mass is measured from the other end of its link
    (``lc1' = l2 - lc2``, ``lc2' = l1 - lc1``)."""
    return replace(p, m1=p.m2, m2=p.m1, l1=p.l2, l2=p.l1, lc1=p.l2 - p.lc2,
                   lc2=p.l1 - p.lc1, I1=p.I2, I2=p.I1)


def swapped_imu(imu: ImuParams, plant: PlantParams) -> ImuParams:
    """The IMUs seen from the other gripper: IMU 2 (on link 2, ``r2`` from the
    elbow) is the new IMU 1 at ``l2 - r2`` from the new holding gripper, IMU 1
    the new IMU 2 at ``l1 - r1`` from the elbow; each error follows its IMU
    (a misalignment is an angle in the link's frame, which turns by pi with
    the link's direction and keeps its value)."""
    return replace(imu, r1=plant.l2 - imu.r2, r2=plant.l1 - imu.r1,
                   gyro_bias1=imu.gyro_bias2, gyro_bias2=imu.gyro_bias1,
                   misalign1=imu.misalign2, misalign2=imu.misalign1,
                   accel_scale1=imu.accel_scale2, accel_scale2=imu.accel_scale1,
                   gyro_scale1=imu.gyro_scale2, gyro_scale2=imu.gyro_scale1)


def swapped(params: BplirParams) -> BplirParams:
    """The robot holding with the gripper of link 2 (every second swing of a
    traversal), derived from ``params``: the nominal and the simulated plant
    swapped (:func:`swapped_plant`), the simulated IMUs moved with their links
    (:func:`swapped_imu`, true link lengths), the estimator's geometry from the
    nominal model (``l1' = l2``, ``r1' = l2 - r2``, ``r2' = l1 - r1``).
    Friction stays: both wrists are the same joint hardware.  ``swapped``
    twice gives ``params`` back when the estimator's ``l1`` is the nominal
    link length (the dissertation preset; the lab firmware's 0.8 m is not)."""
    nominal, true = params.plant, params.true_plant
    est = params.estimator
    return replace(
        params, plant=swapped_plant(nominal),
        true_plant=None if true is None else swapped_plant(true),
        imu=swapped_imu(params.imu, params.simulated_plant),
        estimator=replace(est, l1=nominal.l2, r1=nominal.l2 - est.r2, r2=est.l1 - est.r1))


def parameter_reference(blocks=None) -> list[dict[str, Any]]:
    """One row per parameter of the default set (``blocks``: the block names
    to list, default all but the simulated robot's copies): block, name,
    unit, allowed range, default and one-line meaning."""
    base = BplirParams()
    names = blocks or [b for b in BLOCKS if not b.startswith("true_")]
    rows = []
    for block in names:
        if block not in BLOCKS or block.startswith("true_"):
            raise ParameterError(f"unknown parameter block '{block}'; allowed: "
                                 + ", ".join(b for b in BLOCKS if not b.startswith("true_")))
        value = getattr(base, block)
        for f in fields(value):
            md = f.metadata
            default = getattr(value, f.name)
            if "lo" in md:
                allowed = _range_text(dict(md, unit=""))
            elif isinstance(default, bool):
                allowed = "true, false"
            else:
                allowed = md.get("allowed", "")
            rows.append({"block": block, "name": f.name, "unit": md.get("unit", ""),
                         "range": allowed, "default": default, "doc": md.get("doc", "")})
    return rows


BLOCKS = {
    "plant": PlantParams, "friction": FrictionParams, "motor": MotorParams,
    "imu": ImuParams, "estimator": EstimatorParams, "controller": ControllerParams,
    "path": PathParams, "scenario": ScenarioParams, "drive": DriveParams,
    "traverse": TraverseParams, "line_sensor": LineSensorParams,
    "true_plant": PlantParams, "true_friction": FrictionParams,
}


# ---------------------------------------------------------------- presets
def _dissertation() -> BplirParams:
    return BplirParams(preset_name="dissertation")


def _lab() -> BplirParams:
    """The lab prototype: the estimator geometry of the firmware (r1 = r2 =
    0.5 m, l1 = 0.8 m while the calibrated link is 0.9091 m) and the firmware
    controller (the lab firmware of the dissertation's robot)."""
    return BplirParams(
        estimator=EstimatorParams(r1=0.5, r2=0.5, l1=0.8),
        controller=ControllerParams.preset_named("lab"),
        line_sensor=LineSensorParams(range=0.0),
        preset_name="lab",
    )


PRESETS = {"dissertation": _dissertation, "lab": _lab}


def preset(name: str = "dissertation") -> BplirParams:
    """A named parameter set: ``dissertation`` (Table 4.3) or ``lab``."""
    try:
        return PRESETS[name]()
    except KeyError:
        raise ParameterError(
            f"unknown preset '{name}'; allowed: " + ", ".join(PRESETS)) from None


# ---------------------------------------------------------------- TOML
def from_dict(data: dict[str, Any], base: BplirParams | None = None) -> BplirParams:
    """Build parameters from a nested dict (as read from TOML).

    A top-level ``preset = "name"`` selects the base; every table overrides
    fields of the block of the same name.
    """
    if not isinstance(data, dict):
        raise ParameterError("parameter data must be a table of tables")
    data = dict(data)
    name = data.pop("preset", None)
    if name is not None and not isinstance(name, str):
        raise ParameterError(f"preset = {name!r} must be a string naming a preset")
    params = preset(name) if name else (base or preset("dissertation"))
    updates: dict[str, Any] = {}
    for key, table in data.items():
        if key not in BLOCKS:
            raise ParameterError(
                f"unknown parameter table '[{key}]'; allowed: " + ", ".join(BLOCKS))
        if not isinstance(table, dict):
            raise ParameterError(f"'{key}' must be a table ([{key}]), got {table!r}")
        cls = BLOCKS[key]
        if key.startswith("true_"):
            current = getattr(params, key) or getattr(params, key[len("true_"):])
        else:
            current = getattr(params, key)
        try:
            updates[key] = cls.from_dict(table, base=current)
        except ParameterError as exc:  # name the table the user wrote ([true_plant] ...)
            if key != cls._name:
                raise ParameterError(str(exc).replace(f"{cls._name}.", f"{key}.")) from None
            raise
        except TypeError as exc:  # pragma: no cover - defensive
            raise ParameterError(f"[{key}]: {exc}") from None
    try:
        return replace(params, **updates)
    except TypeError as exc:  # pragma: no cover - defensive
        raise ParameterError(str(exc)) from None


def read_toml(path: str | Path, what: str = "parameter file", error=ParameterError) -> dict:
    """A TOML file as a dict; unreadable, binary, non-UTF-8 or malformed files
    raise ``error`` with a one-line message naming the file (a UTF-8 BOM is
    accepted)."""
    from .io import read_text

    path = Path(path)
    text = read_text(path, what, error)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"malformed TOML in {path}: {exc}") from None


def load_toml(path: str | Path) -> BplirParams:
    """Read a parameter file; errors name the file and the problem."""
    return from_dict(read_toml(path))


def to_dict(params: BplirParams) -> dict[str, Any]:
    """The parameters as a dict of tables (a TOML document)."""
    out: dict[str, Any] = {"preset": params.preset_name}
    for key in BLOCKS:
        block = getattr(params, key)
        if block is not None:
            out[key] = block.as_dict()
    return out


def to_toml(params: BplirParams) -> str:
    """The parameters as TOML text."""
    import tomli_w

    return tomli_w.dumps(to_dict(params))


def save_toml(params: BplirParams, path: str | Path) -> None:
    """Write the parameters as TOML at ``path`` (atomic)."""
    from .io import write_text_atomic

    write_text_atomic(path, to_toml(params))


def as_jsonable(params: BplirParams) -> dict[str, Any]:
    """The parameters as JSON-ready data (= :func:`to_dict`)."""
    return to_dict(params)


__all__ = [
    "ParameterError", "PlantParams", "FrictionParams", "MotorParams", "ImuParams",
    "EstimatorParams", "LineSensorParams", "ControllerParams", "PathParams", "ScenarioParams",
    "BplirParams", "preset", "PRESETS", "HARDWARE_OPTIONS", "LINE_SENSOR_OPTION",
    "from_dict", "load_toml", "to_toml",
    "save_toml", "to_dict", "sigma_from_density", "DriveParams", "TraverseParams",
    "swapped", "swapped_plant", "swapped_imu", "parameter_reference", "BLOCKS", "plugin_name",
]
