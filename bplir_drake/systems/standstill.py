"""Standstill calibration of the IMUs before a swing.

Before a swing both grippers hold the line: the pose is known (the joint
encoders and the grip geometry) and the robot is at rest.  Over a window of
samples there, each gyro reads only its bias (plus noise) and each
accelerometer reads gravity in its link frame, ``(g sin theta_i, g cos
theta_i)`` (:func:`~bplir_drake.systems.imu.imu_kinematics` at rest), seen
through its mounting misalignment ``eps_i`` and scale error ``s_i``:
``(1 + s_i) g (sin(theta_i + eps_i), cos(theta_i + eps_i))``
(:func:`~bplir_drake.systems.imu.corrupt`).  So

* gyro bias ``b_i`` = mean gyro reading;
* misalignment ``eps_i = atan2(mean a_x, mean a_y) - theta_i``;
* scale ``s_i = |mean a| / g - 1``;
* the sensors' white noise per sample: the window's scatter (pooled over
  both gyros, and over the four accelerometer axes), which lets the filter
  widen its measurement noise when the sensors are noisier than its tuning
  assumes (:meth:`~bplir_drake.params.EstimatorParams.with_measured_noise`).

:func:`calibrate_standstill` estimates them from the samples (what the
robot measures -- never the simulated sensor's parameters) and reports the
residual (the standard error of each estimate from the window's scatter);
:meth:`ImuCalibration.correct` removes misalignment and scale from a
sample.  The gyro biases initialise the EKF's bias states.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ImuCalibration:
    """Gyro biases (rad/s), accelerometer misalignments (rad) and scale
    errors of both IMUs, with the standard errors of the biases (rad/s)
    and misalignments (rad) from the calibration window, the measured
    noise per sample ``(gyro rad/s, accelerometer m/s^2)`` (0: not
    measured) and the line range sensor's offset (m: its mean reading
    while the free gripper holds the line, where the gap is 0; removed
    from every reading of the swing)."""

    bias: tuple = (0.0, 0.0)
    misalign: tuple = (0.0, 0.0)
    scale: tuple = (0.0, 0.0)
    bias_sigma: tuple = (0.0, 0.0)
    misalign_sigma: tuple = (0.0, 0.0)
    samples: int = 0
    noise: tuple = (0.0, 0.0)
    line_offset: float = 0.0

    def correct(self, sample) -> np.ndarray:
        """``sample`` (6, ``IMU_COLUMNS`` order) with each accelerometer's
        misalignment and scale removed (the gyro biases stay: the filter
        estimates them, starting from :attr:`bias`)."""
        out = np.array(sample, dtype=float)
        if not any(self.misalign) and not any(self.scale):  # nothing to correct
            return out
        for i in range(2):
            eps, k = self.misalign[i], 1.0 + self.scale[i]
            ax, ay = out[2 + 2 * i], out[3 + 2 * i]
            c, s = math.cos(eps), math.sin(eps)
            out[2 + 2 * i] = (c * ax - s * ay) / k
            out[3 + 2 * i] = (s * ax + c * ay) / k
        return out

    def summary(self) -> dict:
        """The estimates and their standard errors as JSON-ready data."""
        return {"gyro_bias_rad_s": list(self.bias), "misalignment_rad": list(self.misalign),
                "accel_scale_error": list(self.scale),
                "gyro_bias_sigma_rad_s": list(self.bias_sigma),
                "misalignment_sigma_rad": list(self.misalign_sigma), "samples": self.samples,
                "gyro_noise_rad_s": self.noise[0], "accel_noise_m_s2": self.noise[1],
                "line_sensor_offset_m": self.line_offset}


def calibrate_standstill(samples, theta, g: float) -> ImuCalibration:
    """The calibration from ``samples`` (N, 6) taken at rest at the absolute
    link angles ``theta`` (rad, known from the grip geometry) under gravity
    ``g`` (m/s^2)."""
    samples = np.asarray(samples, dtype=float)
    n = len(samples)
    if n < 2:
        raise ValueError("a standstill calibration needs at least 2 samples")
    mean = samples.mean(axis=0)
    var = samples.var(axis=0, ddof=1)
    sem = np.sqrt(var / n)
    misalign, scale, eps_sigma = [], [], []
    for i in range(2):
        ax, ay = mean[2 + 2 * i], mean[3 + 2 * i]
        magnitude = math.hypot(ax, ay)
        eps = math.atan2(ax, ay) - theta[i]
        misalign.append(math.remainder(eps, math.tau))
        scale.append(magnitude / g - 1.0)
        eps_sigma.append(math.hypot(sem[2 + 2 * i], sem[3 + 2 * i]) / magnitude)
    def floats(v):
        return tuple(float(x) for x in v)

    noise = (math.sqrt(var[:2].mean()), math.sqrt(var[2:].mean()))
    return ImuCalibration(floats(mean[:2]), floats(misalign), floats(scale), floats(sem[:2]),
                          floats(eps_sigma), n, floats(noise))
