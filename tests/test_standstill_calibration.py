"""The standstill calibration before a swing (issue 17): gyro biases,
accelerometer misalignments and scale errors from samples at rest in the
known start pose, and what it does for swings with biased, misaligned IMUs."""
import dataclasses as dc
import math
from pathlib import Path

import numpy as np
import pytest

from bplir_drake.params import ImuParams
from bplir_drake.systems.calibration import ImuCalibration, calibrate_standstill
from bplir_drake.systems.imu import corrupt, imu_kinematics, standstill_samples

STUDY = Path(__file__).resolve().parents[1] / "examples" / "study_realistic.toml"


def test_calibration_recovers_bias_misalignment_and_scale():
    rng = np.random.default_rng(3)
    for k in range(20):
        true = dc.replace(ImuParams(), gyro_bias1=rng.uniform(-0.03, 0.03),
                          gyro_bias2=rng.uniform(-0.03, 0.03),
                          misalign1=rng.uniform(-0.0436, 0.0436),
                          misalign2=rng.uniform(-0.0436, 0.0436),
                          accel_scale1=rng.uniform(-0.02, 0.02),
                          accel_scale2=rng.uniform(-0.02, 0.02))
        theta = (rng.uniform(-0.6, 0.6), rng.uniform(-2.8, 2.8))
        cal = calibrate_standstill(standstill_samples(true, theta, 9.81, k, 500), theta, 9.81)
        # within 4 standard errors of the window (bias: sigma / sqrt(500))
        for i, b in enumerate((true.gyro_bias1, true.gyro_bias2)):
            assert abs(cal.bias[i] - b) < 4 * cal.bias_sigma[i]
        for i, e in enumerate((true.misalign1, true.misalign2)):
            assert abs(cal.misalign[i] - e) < 4 * cal.misalign_sigma[i] + 1e-12
        for i, s in enumerate((true.accel_scale1, true.accel_scale2)):
            assert abs(cal.scale[i] - s) < 1e-3
        assert cal.bias_sigma[0] == pytest.approx(true.gyro_sigma / math.sqrt(500), rel=0.2)


def test_correction_inverts_the_sensor_error_model_exactly():
    true = dc.replace(ImuParams(), misalign1=0.04, misalign2=-0.03, accel_scale1=0.01,
                      accel_scale2=-0.02, noise=False)
    cal = ImuCalibration(misalign=(0.04, -0.03), scale=(0.01, -0.02))
    rng = np.random.default_rng(0)
    for _ in range(50):
        ideal = imu_kinematics(rng.normal(size=2), rng.normal(size=2), rng.normal(size=2),
                               0.5, 0.5, 0.9091, 9.81)
        measured = corrupt(ideal, true, np.zeros(2), rng)
        np.testing.assert_allclose(cal.correct(measured), ideal, rtol=0, atol=1e-12)


def _imu_group(standstill: int, seed: int, n: int) -> list[int]:
    from bplir_drake.analysis.montecarlo import load_study, run_sample

    st = load_study(STUDY)
    p = st.params
    st = st.with_(distributions=tuple(d for d in st.distributions if d.name.startswith("imu.")),
                  samples=n, seed=seed,
                  params=p.with_(scenario=dc.replace(p.scenario, gust_rate=0.0),
                                 estimator=dc.replace(p.estimator,
                                                      standstill_samples=standstill)))
    return [k for k in range(n) if not run_sample(st, k)["success"]]


def test_calibration_captures_swings_with_biased_misaligned_imus():
    """The realistic study's IMU errors alone (bias +/-0.03 rad/s,
    misalignment +/-2.5 deg, noise x0.5-2), EKF in the loop.  Held-out seeds:
    root seed 1 (the calibration's only choice, 500 samples = 5 s, was made
    on root seed 0).  Measured: 10 of 12 captured with the calibration; 0 of
    the first 6 without it."""
    assert len(_imu_group(500, 1, 12)) <= 2
    assert len(_imu_group(0, 1, 6)) == 6
