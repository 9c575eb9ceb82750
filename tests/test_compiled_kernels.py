"""The compiled per-tick arithmetic against the plain functions it stands in
for: the EKF step, the IMU error model, the nominal model's rates and the
tracker's law."""
import dataclasses as dc

import numpy as np
import pytest

from bplir_drake.params import EstimatorParams, ImuParams, preset
from bplir_drake.systems import ekf_kernel, imu, nominal_kernel
from bplir_drake.systems.ekf import ekf_step, initial_state
from bplir_drake.systems.kernels import read_only   # as the systems pass their state
from bplir_drake.systems.predictor import nominal_rates


@pytest.fixture(scope="module")
def swing_samples():
    """(the IMU samples (N, 6) of the default swing, seed 0; the absolute
    start state the robot believes)."""
    from bplir_drake.analysis.swing.swing_runner import run_swing
    from bplir_drake.diagrams.swing_setup import believed_start
    from bplir_drake.systems.plant import absolute_from_relative

    x0 = absolute_from_relative(np.r_[believed_start(preset())[:2], 0.0, 0.0])
    return run_swing(preset(), seed=0).logs["imu"].data, x0


LAYOUTS = {"bias": {}, "misalignment": {"estimate_misalignment": True},
           "all": {"estimate_misalignment": True, "estimate_gyro_scale": True,
                   "estimate_imu_position": True}}


@pytest.mark.slow
@pytest.mark.parametrize("integration", ["euler", "trapezoid", "heun"])
@pytest.mark.parametrize("layout", list(LAYOUTS))
@pytest.mark.parametrize("inflate", [0.0, 3.0])
def test_the_compiled_filter_step_is_the_readable_one(swing_samples, integration, layout,
                                                      inflate):
    """Over a whole swing's samples, every state layout, integration and
    covariance inflation: the compiled step's state and covariance are
    :func:`ekf_step`'s to rounding (relative 1e-8), the Schmidt holds
    included (the first 0.2 s hold the extra states, the misalignments
    throughout)."""
    p = dc.replace(EstimatorParams(), integration=integration, inflate_nis=inflate,
                   **LAYOUTS[layout])
    samples, x0 = swing_samples
    s = initial_state(p, x0, (p.start_angle_sigma, p.start_rate_sigma, p.start_bias_sigma))
    consts, walk = ekf_kernel.pack(p)
    x, P, u = read_only(s.x), read_only(s.P), read_only(np.zeros(4))
    u_ref = np.zeros(4)
    worst = 0.0
    for k, sample in enumerate(samples):
        hold, hold_mis = k < 20, layout != "bias"
        s, u_ref = ekf_step(s, u_ref, sample, p, first=k == 0, hold=hold, hold_misalign=hold_mis)
        x, P, u = map(read_only, ekf_kernel.step(x, P, u, np.array(sample, float), k == 0,
                                                 hold, hold_mis, consts, walk, np.zeros(4)))
        worst = max(worst, np.abs(x - s.x).max() / (1.0 + np.abs(s.x).max()),
                    np.abs(P - s.P).max() / np.abs(s.P).max(), np.abs(u - u_ref).max())
    assert worst < 1e-8


def test_the_compiled_calibration_correction_is_the_calibrations():
    """A standstill calibration's misalignment and scale removed in the
    compiled step (``cal``) equal :meth:`ImuCalibration.correct` followed by
    the plain step."""
    from bplir_drake.systems.standstill import ImuCalibration

    p = EstimatorParams()
    cal = ImuCalibration(misalign=(0.03, -0.02), scale=(0.01, -0.015))
    s = initial_state(p, (0.05, -0.1, 0.0, 0.0))
    sample = np.array([0.1, -0.2, 0.4, 9.7, -0.3, 9.9])
    ref, u_ref = ekf_step(s, np.zeros(4), cal.correct(sample), p, first=True)
    x, P, u = ekf_kernel.step(read_only(s.x), read_only(s.P), read_only(np.zeros(4)), sample,
                              True, False, False, *ekf_kernel.pack(p),
                              np.array([*cal.misalign, *cal.scale]))
    np.testing.assert_allclose(x, ref.x, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(P, ref.P, rtol=1e-12, atol=1e-16)
    np.testing.assert_allclose(u, u_ref, rtol=1e-12)


def test_the_compiled_sensor_error_model_is_corrupt():
    """The sampler's compiled error model, on the tick's drawn normals, is
    :func:`imu.corrupt` with the walk stepped first (its draws 0-1), the
    white noise its draws 2-7."""
    p = dc.replace(ImuParams(), gyro_bias1=0.02, gyro_bias2=-0.01, misalign1=0.03,
                   misalign2=-0.02, accel_scale1=0.01, accel_scale2=-0.015, gyro_scale1=0.002,
                   gyro_scale2=-0.003, gyro_drift=0.01)
    draws = np.random.default_rng(5).standard_normal(8)
    ideal = np.array([0.3, -1.2, 0.8, 9.6, -2.1, 10.4])
    walk = np.array([0.001, -0.002]) + p.gyro_drift * np.sqrt(p.period) * draws[:2]

    class Drawn:   # the rng corrupt() asks for its white noise
        def standard_normal(self, n):
            return draws[2:2 + n]

    expected = imu.corrupt(ideal, p, np.array([p.gyro_bias1, p.gyro_bias2]) + walk, Drawn())
    out = imu.sample_kernel(*ideal, 0.001, -0.002, 7, imu.pack(p), read_only(draws))
    np.testing.assert_allclose(out[:6], expected, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(out[6:8], walk, rtol=1e-14)
    assert out[8] == 8.0


def test_the_compiled_nominal_model_is_the_plain_one():
    """The compiled rates, link 1's passive acceleration and the elbow's
    computed torque agree with the plain closed form to rounding, friction
    on, at 200 random states."""
    p = preset()
    c = nominal_kernel.pack(p.plant, p.friction)
    f = nominal_rates(p.plant, p.friction)
    rng = np.random.default_rng(11)
    for _ in range(200):
        q1, q2, v1, v2, tau = rng.uniform(-3, 3, 5)
        np.testing.assert_allclose(nominal_kernel.rates(c, q1, q2, v1, v2, tau),
                                   f(q1, q2, v1, v2, tau), rtol=1e-12, atol=1e-12)
        a2 = f(q1, q2, v1, v2, tau)[3]
        assert nominal_kernel.link1_accel(c, q1, q2, v1, v2, a2) == pytest.approx(
            f(q1, q2, v1, v2, tau)[2], rel=1e-9, abs=1e-9)
        assert nominal_kernel.elbow_torque(c, q1, q2, v1, v2, a2) == pytest.approx(
            tau, rel=1e-9, abs=1e-9)


def test_the_compiled_gain_sum_rounds_once_a_term():
    """``gain_sum`` is the first product rounded and each next one fused
    into the running sum (one rounding per term, checked in exact rational
    arithmetic at 2000 random rows), and within 4 ulp of the plain sum."""
    from fractions import Fraction

    from bplir_drake.systems.tracker_kernel import gain_sum
    rng = np.random.default_rng(3)
    for _ in range(2000):
        K = rng.normal(size=4) * 10.0 ** rng.uniform(-2, 3, 4)
        d = rng.normal(size=4) * 10.0 ** rng.uniform(-4, 1, 4)
        s = float(K[0] * d[0])
        for j in range(1, 4):
            s = float(Fraction(K[j]) * Fraction(d[j]) + Fraction(s))
        assert gain_sum(K, d) == s
        assert abs(gain_sum(K, d) - float(K @ d)) <= 4 * np.spacing(np.abs(K * d).sum())


@pytest.mark.parametrize("envelope", [True, False])
@pytest.mark.parametrize("limit", [3.0, 20.0, 100.0])
def test_the_compiled_torque_window_is_the_motors(envelope, limit):
    """The tracker's compiled torque window is
    :func:`~bplir_drake.systems.motor.torque_window_of`'s, bit for bit, at
    2000 elbow rates (the voltage envelope on and off, three torque
    limits); with no motor it is the limit alone."""
    from bplir_drake.systems.motor import torque_window_of
    from bplir_drake.systems.tracker_kernel import window, window_constants
    m = dc.replace(preset().resolved().motor, envelope=envelope)
    plain, c = torque_window_of(m, torque_limit=limit), window_constants(m, limit)
    for q2d in np.random.default_rng(4).normal(size=2000) * 30.0:
        assert window(q2d, c) == plain(q2d)
    assert window(5.0, window_constants(None, limit)) == (-limit, limit)


def _terminal_laws(p):
    """The apex shot, the aim landing and the reach of the default robot at 0 deg."""
    from bplir_drake.systems.landing import ApexShot, Landing, Reach
    lp = p.landing
    return {"shoot": ApexShot.from_params(p.plant, p.friction, 0.0, lp),
            "aim": Landing.from_params(p.plant, 0.0, lp),
            "reach": Reach.from_params(p.plant, 0.0, dc.replace(lp, landing_law="reach",
                                                                reach_speed=0.3))}


def test_the_compiled_takeover_is_the_terminal_laws():
    """The compiled take-over test of each terminal law is its ``takes_over``
    at 3000 states near the line's (both ways), and the height and link 1's
    deceleration are the laws', bit for bit."""
    from bplir_drake.systems import tracker_kernel as tk
    from bplir_drake.systems.landing import height_rates, terminal_rule
    p = preset()
    rng = np.random.default_rng(8)
    states = np.column_stack([rng.uniform(1.2, 2.6, 3000), rng.uniform(-1.5, 1.5, 3000),
                              rng.uniform(-1.0, 3.0, 3000), rng.uniform(-6.0, 6.0, 3000)])
    for name, law in _terminal_laws(p).items():
        rule = terminal_rule(law)
        said = [tk.takes_over(x, rule) for x in states]
        assert said == [law.takes_over(x) for x in states], name
        assert 300 < sum(said) < 2700, (name, sum(said))   # both answers are asked
    landing = _terminal_laws(p)["aim"]
    c = np.array(landing.decel_constants())
    for x in states[:500]:
        assert tk.height(x, 0.0, p.plant.l1, p.plant.l2) == height_rates(p.plant, 0.0, x)[0]
        assert tk.deceleration(x, c) == landing.deceleration(x)


@pytest.mark.parametrize("brake", [0.0, 0.8])
def test_the_compiled_apex_shot_is_the_laws(brake):
    """The compiled apex shot gives :meth:`ApexShot.torque` bit for bit at
    1500 states about the line (the motor's window, with and without the
    brake ratio): where it solves a shot, it gives up, it brakes or it
    caps the elbow's rate; where no shot is solved it says so (the law
    then runs the landing)."""
    from bplir_drake.systems import tracker_kernel as tk
    from bplir_drake.systems.landing import terminal_rule
    p = preset()
    shot = dc.replace(_terminal_laws(p)["shoot"], brake_ratio=brake, give_up_rate=0.1)
    rule, c = terminal_rule(shot), tk.window_constants(p.motor, 20.0)
    rng = np.random.default_rng(9)
    states = np.column_stack([rng.uniform(1.3, 2.3, 1500), rng.uniform(-1.2, 1.2, 1500),
                              rng.uniform(-0.6, 2.5, 1500), rng.uniform(-3.0, 3.0, 1500)])
    solved = 0
    for x in states:
        lo, hi = tk.window(x[3], c)
        found, u = tk.shot_torque(x, rule, shot.constants, lo, hi)
        assert found == (shot.gives_up(x) or shot.solve(x) is not None)
        if found:
            assert u == shot.torque(x, window=(lo, hi))
            solved += 1
    assert 300 < solved < 1500
