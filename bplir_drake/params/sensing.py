"""What the robot senses and how it estimates: the IMUs, the jaw's line range sensor, and the kinematic EKF's settings."""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from .blocks import ParameterError, _Block, _count, _length, _p, _positive


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
    estimator fuses it (:mod:`bplir_drake.systems.line_sensor`) where the
    jaws carry one (``fitted``; not: the IMUs alone, the dissertation's
    robot)."""

    _name = "line_sensor"
    fitted: bool = field(default=False, metadata=dict(doc="the jaws carry the sensor (false: the IMUs alone, the dissertation's robot)"))
    range: float = _p(0.2, "m", 0, 1, lo_open=True, doc="largest gripper-to-line distance the sensor reads")
    sigma: float = _p(0.001, "m", 0, 0.05, doc="white noise per sample")
    offset: float = _p(0.0, "m", -0.02, 0.02, doc="constant reading error (mounting): the sensor reads the distance plus this")
    filter_sigma: float = _positive(0.0015, "m", doc="the noise the estimator assumes for a reading (its R)")


def sigma_from_density(density: float, rate_hz: float) -> float:
    """Per-sample standard deviation of white noise with the given density."""
    return density * math.sqrt(rate_hz)


# ---------------------------------------------------------------- estimator
#: the dissertation's filter tuning, (5.39)-(5.40) with explicit Euler (5.3)
CHAPTER5_TUNING = {"accel_process_sigma": 0.427, "accel_meas_sigma": 0.427,
                   "gyro_meas_sigma": 0.02, "integration": "euler",
                   "estimate_misalignment": False}


@dataclass(frozen=True)
class EstimatorParams(_Block):
    """Kinematic EKF: geometry and noise only.

    No mass, inertia or friction may appear here (the filter is kinematic).

    The fields are the filter of a swing, which starts from its known pose
    on the line: it trusts the gyros (R the IMUs' Table 5.1 noise), takes
    Heun's second-order step and goes on estimating each accelerometer's
    misalignment from the standstill calibration's value.  It can lock onto
    a wrong solution from a 1 rad initial error; estimating from an unknown
    pose, :meth:`chapter5` gives the dissertation's tuning ((5.39)-(5.40)
    with explicit Euler (5.3)), which converges from 1 rad errors in about
    0.25 s but lags by about 30 ms inside a control loop.
    """

    _name = "estimator"

    def _check(self):
        if self.r1 > self.l1:
            raise ParameterError(f"estimator.r1 = {self.r1:g} m exceeds estimator.l1 = "
                                 f"{self.l1:g} m; allowed (0, l1]")
        self._check_plugin()
        self._one_of("integration", ("euler", "trapezoid", "heun"))

    r1: float = _length(0.5, doc="IMU 1 distance from joint 1 (filter geometry)")
    r2: float = _length(0.5, doc="IMU 2 distance from the elbow")
    l1: float = _length(0.9091, doc="link 1 length (filter geometry)")
    g: float = _p(9.81, "m/s^2", 0, 30, lo_open=True, doc="gravity used by the filter")
    period: float = _p(0.01, "s", 0, 1, lo_open=True, doc="filter period (100 Hz)")
    accel_process_sigma: float = _positive(0.2, "m/s^2", doc="process noise on the accelerometer inputs (the part of a link's acceleration the kinematic model does not predict)")
    gyro_meas_sigma: float = _positive(0.0166, "rad/s", doc="gyro measurement noise per sample the filter assumes, its gyro R (Table 5.1); a standstill calibration measuring more widens R by the ratio")
    accel_meas_sigma: float = _positive(0.1, "m/s^2", doc="accelerometer measurement noise the filter assumes, its accelerometer R")
    # Heun's step takes the accelerations at both ends of the period: its
    # smaller discretisation error lets the filter trust the accelerometers'
    # gravity 10x more than the trapezoid (process noise 0.2, not 2.0 m/s^2)
    integration: str = field(default="heun", metadata=dict(doc="prediction step: euler (5.3), trapezoid, or heun (the accelerations at both ends of the period)", allowed="euler, trapezoid, heun"))
    p0_angle: float = _positive(1.0, "rad", doc="initial angle standard deviation")
    p0_rate: float = _positive(0.5, "rad/s", doc="initial rate standard deviation")
    start_angle_sigma: float = _positive(0.02, "rad", doc="initial angle sd when a swing starts at rest on the line, about the pose the robot believes it is in")
    start_rate_sigma: float = _positive(0.05, "rad/s", doc="initial rate sd at a swing start (at rest)")
    start_bias_sigma: float = _positive(0.002, "rad/s", doc="gyro-bias sd at a swing start (calibrated while held on the line)")
    standstill_samples: int = _count(500, "samples", 0, 100000, doc="IMU samples averaged at rest on the line before a swing to calibrate gyro biases and misalignments (0: none, the dissertation's filter; 500 = 5 s)")
    tuned_accel_noise: float = _positive(0.02156, "m/s^2", doc="accelerometer noise per sample the filter's accel_meas_sigma was set for (Table 5.1); a standstill calibration measuring more widens R by the ratio")
    noise_tolerance: float = _p(1.2, "", 1, 100, doc="R is widened only when the measured noise exceeds the tuned one by more than this factor (500 samples measure it within 6 %)")
    inflate_nis: float = _p("never", "", 0, 1000, lo_open=True, off="never", doc="covariance inflation: a tick whose normalised innovation squared exceeds this multiple of its expectation inflates the predicted covariance by the excess (never: no inflation)")
    misalign_max_noise: float = _p(3.0, "", 1, 100, doc="misalignment states are held at the standstill calibration's values when it measures the IMUs noisier than this many times the tuned noise (their in-flight estimate then wanders)")
    estimate_bias: bool = field(default=True, metadata=dict(doc="estimate a constant gyro bias per IMU (two extra states)"))
    bias_sigma0: float = _positive(0.05, "rad/s", doc="initial gyro-bias standard deviation")
    bias_walk: float = _positive(1e-3, "rad/s/sqrt(s)", doc="gyro-bias random walk")
    estimate_misalignment: bool = field(default=True, metadata=dict(doc="estimate each accelerometer's misalignment (in a swing from the standstill calibration's value)"))
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
    plugin: str = field(default="", metadata=dict(doc="module:factory (or registered name) of your own estimator, used in a swing instead of the EKF ('' : the EKF)", allowed="module:factory, a registered name or ''"))
    plugin_args: tuple = field(default=(), metadata=dict(doc="keyword arguments of the plug-in's factory, each 'key=value' (numbers, true/false or text)"))

    def chapter5(self) -> "EstimatorParams":
        """The same filter with the dissertation's tuning for estimating from
        an unknown pose: (5.39)-(5.40) with explicit Euler (5.3), no
        misalignment states (:data:`CHAPTER5_TUNING`)."""
        return replace(self, **CHAPTER5_TUNING)

    def self_calibrating(self) -> "EstimatorParams":
        """The same filter with the self-calibration states (accelerometer
        misalignment, gyro scale and IMU distance beside the gyro biases),
        Heun's second-order step (explicit Euler lags the angles by half a
        period, 5 ms; a step that takes gravity at the period's start
        biases the calibration states, see
        :func:`bplir_drake.systems.ekf.discrete_f`) and those states held
        for the first 2 s, while the angles converge from an unknown start
        (``bplir estimate --self-calibrate``)."""
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
        ``accel`` m/s^2), by its ratio to ``gyro_meas_sigma`` and
        ``tuned_accel_noise`` where that is
        above ``noise_tolerance`` (never narrowed; 0: not measured,
        unchanged)."""
        def widen(ratio):
            return ratio if ratio > self.noise_tolerance else 1.0

        kg = widen(gyro / self.gyro_meas_sigma)
        ka = widen(accel / self.tuned_accel_noise)
        if kg == 1.0 and ka == 1.0:
            return self
        return replace(self, gyro_meas_sigma=self.gyro_meas_sigma * kg,
                       accel_meas_sigma=self.accel_meas_sigma * ka)
