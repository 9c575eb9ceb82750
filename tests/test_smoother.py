"""The Rauch-Tung-Striebel smoother over the kinematic EKF and the NIS
consistency check (issue 20).

Tuning of the consistent filter: R is the simulated sensors' noise (Table
5.1), Q on the accelerometer inputs 0.2 m/s^2 -- chosen on seed 1 (mean
NIS 3.92, 20 s log); the tests check seeds 2 and 3 (held out)."""
import dataclasses as dc
import functools

import numpy as np
import pytest

from bplir_drake.analysis.estimation.filter_study import simulate_estimation
from bplir_drake.estimation import estimate
from bplir_drake.params import preset


def consistent(p):
    """The in-loop filter with R = the simulated IMUs' noise and Q tuned on
    seed 1, with the trapezoid step it was tuned with (with Heun's step,
    the in-loop default, seed 3's mean
    NIS is 3.876, a hair under its band: the smaller discretisation error
    leaves smaller innovations)."""
    return dc.replace(p.estimator, gyro_meas_sigma=p.imu.gyro_sigma,
                      accel_meas_sigma=p.imu.accel_sigma, accel_process_sigma=0.2,
                      bias_walk=1e-4, integration="trapezoid")


#: the logs: seed and IMU changes
LOGS = {"seed 2": (2, {}), "seed 3": (3, {}),
        "seed 4, gyro biases": (4, {"gyro_bias1": 0.02, "gyro_bias2": -0.03})}


@functools.lru_cache(maxsize=None)
def _run(name):
    """The 20 s log ``name`` (simulated once per test process, when first
    asked for: the test workers each simulate only the logs their tests use)."""
    seed, imu = LOGS[name]
    p = preset()
    p = p.with_(imu=dc.replace(p.imu, **imu))
    return p, simulate_estimation(p, duration=20.0, seed=seed)


def _rmse(x, run, t_from=5.0):
    m = run.t >= t_from
    return np.sqrt(np.mean((x[m, :2] - run.truth[m, :2]) ** 2, axis=0))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["seed 2", "seed 3"])
def test_nis_of_a_consistent_filter_lies_in_its_95_percent_band(name):
    p, run = _run(name)
    check = estimate(run.t, run.imu, consistent(p), run.x0_estimate).nis_check()
    assert check["updates"] == len(run.t)
    assert check["band"] == pytest.approx([3.877, 4.125], abs=2e-3)  # chi2(4 N) / N, N = 2000
    assert check["consistent"], check
    # the dissertation's tuning (5.39)-(5.40) is far too cautious: NIS ~1.1
    loose = estimate(run.t, run.imu, p.estimator.chapter5(), run.x0_estimate).nis_check()
    assert loose["mean_nis"] < 1.3 and not loose["consistent"]


@pytest.mark.slow
@pytest.mark.parametrize("name", ["seed 2", "seed 3", "seed 4, gyro biases"])
def test_the_smoother_beats_the_filter(name):
    p, run = _run(name)
    for est in (p.estimator.chapter5(), p.estimator, consistent(p)):
        r = estimate(run.t, run.imu, est, run.x0_estimate, smooth=True)
        filt, smooth = _rmse(r.x, run), _rmse(r.smoothed, run)
        assert np.all(smooth < filt), (est.integration, filt, smooth)
        # the backward pass only removes uncertainty; it ends where the filter ends
        assert np.all(r.smoothed_cov_diag <= r.cov_diag * (1 + 1e-9) + 1e-15)
        np.testing.assert_allclose(r.smoothed[-1], r.x[-1])
