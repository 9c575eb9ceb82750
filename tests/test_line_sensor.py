"""The jaw's line range sensor (``line_sensor``) and its fusion in the EKF."""
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from bplir_drake.params import LineSensorParams, ParameterError, preset
from bplir_drake.systems.ekf import EkfState, ekf_gap_update
from bplir_drake.systems.line_sensor import LineSensor, line_gap
from bplir_drake.systems.landing import height_rates
from bplir_drake.systems.plant import initial_configuration
from bplir_drake.params import with_hardware, imu_only


def test_the_gap_is_zero_where_both_grippers_hold_the_line_and_its_gradient_exact():
    p = preset().plant
    for spacing in (1.1, 1.2, 1.3):
        for incline in (-20.0, 0.0, 20.0):
            a = math.radians(incline)
            q = initial_configuration(spacing, p, a)
            assert line_gap(q[0], q[0] + q[1], p.l1, p.l2, a)[0] == pytest.approx(0.0, abs=1e-12)
    a, t1, t2, h = 0.3, 0.4, -1.9, 1e-6
    gap, d1, d2 = line_gap(t1, t2, p.l1, p.l2, a)
    assert d1 == pytest.approx((line_gap(t1 + h, t2, p.l1, p.l2, a)[0]
                                - line_gap(t1 - h, t2, p.l1, p.l2, a)[0]) / (2 * h), rel=1e-7)
    assert d2 == pytest.approx((line_gap(t1, t2 + h, p.l1, p.l2, a)[0]
                                - line_gap(t1, t2 - h, p.l1, p.l2, a)[0]) / (2 * h), rel=1e-7)
    # the terminal laws' distance to the line, with the other sign
    assert gap == pytest.approx(-height_rates(p, a, [t1, t2 - t1, 0.0, 0.0])[0], abs=1e-12)


def _readings(sensor_params, state, ticks=1, alpha=0.0):
    p = preset().plant
    b = DiagramBuilder()
    src = b.AddSystem(ConstantVectorSource(np.asarray(state, dtype=float)))
    sensor = b.AddSystem(LineSensor(sensor_params, p.l1, p.l2, alpha, 0.01, seed=3))
    b.Connect(src.get_output_port(), sensor.state_port)
    diagram = b.Build()
    sim = Simulator(diagram)
    ctx = sensor.GetMyContextFromRoot(sim.get_mutable_context())
    out = []
    for k in range(ticks):
        sim.AdvanceTo(0.01 * k)
        out.append(sensor.GetOutputPort("line_gap").Eval(ctx).copy())
    return np.array(out)


def test_the_sensor_reads_the_true_gap_plus_its_offset_and_noise_within_range():
    p = preset().plant
    # 30 mm below the line at the mirror of the start pose, lifted by link 1
    q = -initial_configuration(1.2, p)
    q[0] -= 0.03 / p.l1
    gap = line_gap(q[0], q[0] + q[1], p.l1, p.l2, 0.0)[0]
    assert 0.02 < gap < 0.04
    exact = _readings(LineSensorParams(fitted=True, range=0.1, sigma=0.0, offset=0.002), [*q, 0, 0])[0]
    assert exact == pytest.approx([gap + 0.002, 1.0], abs=1e-12)
    noisy = _readings(LineSensorParams(fitted=True, range=0.1, sigma=0.001), [*q, 0, 0], ticks=400)
    assert np.all(noisy[:, 1] == 1.0)
    # 400 samples: the sample std within +-10 % of sigma (chi-square, ~3.5 sd)
    assert np.std(noisy[:, 0] - gap, ddof=1) == pytest.approx(0.001, rel=0.1)
    assert abs(np.mean(noisy[:, 0] - gap)) < 4 * 0.001 / 20
    short = _readings(LineSensorParams(fitted=True, range=0.02, sigma=0.001), [*q, 0, 0])[0]
    assert list(short) == [0.0, 0.0]   # out of range: no reading
    with pytest.raises(ValueError, match="fitted is false"):
        LineSensor(LineSensorParams(), p.l1, p.l2, 0.0, 0.01)
    with pytest.raises(ParameterError, match=r"line_sensor.range = -0.1 is out of range"):
        LineSensorParams(range=-0.1)


def test_a_reading_moves_the_estimated_gap_by_the_kalman_share():
    """Scalar update: the gap's innovation shrinks to ``sigma^2 / (H P H' +
    sigma^2)`` of itself (to first order: a 0.5 mm innovation)."""
    p = preset().plant
    q = -initial_configuration(1.2, p)
    x = np.array([q[0] + 1e-3, q[0] + q[1] - 1e-3, 0.1, -0.2, 0.0, 0.0])
    P = np.diag([4e-6, 9e-6, 1e-4, 1e-4, 1e-6, 1e-6])
    P[0, 1] = P[1, 0] = 2e-6
    sigma = 0.0015
    gap, d1, d2 = line_gap(x[0], x[1], p.l1, p.l2, 0.0)
    reading = gap + 5e-4
    H = np.array([d1, d2, 0, 0, 0, 0])
    share = sigma ** 2 / (H @ P @ H + sigma ** 2)
    post = ekf_gap_update(EkfState(x, P), reading, (p.l1, p.l2, 0.0, sigma))
    new = line_gap(post.x[0], post.x[1], p.l1, p.l2, 0.0)[0]
    assert (reading - new) == pytest.approx((reading - gap) * share, rel=1e-3)
    # and the gap's variance falls by the same share
    assert H @ post.P @ H == pytest.approx((H @ P @ H) * share, rel=1e-9)


def test_the_sensor_removes_the_landing_error_that_link_length_errors_leave():
    """With the IMUs alone the standstill calibration takes the pose the
    robot believes (nominal lengths) for the true one; the misalignments it
    removes carry the start pose's height error ``L`` back to the mirrored
    landing, about twice over.  Estimating the misalignments in flight (the
    default) takes part of it out; the line sensor takes all of it out.
    Noise-free IMUs, seed 0, L = 3.27 / -3.27 / 0.51 mm: landing height
    errors 6.84 / -4.14 / 0.60 mm without the in-flight estimate, 3.22 /
    -0.37 / 0.70 mm with it, within 0.10 mm with the sensor."""
    import dataclasses as dc

    from bplir_drake.analysis.swing.swing_runner import run_swing

    p0 = preset()
    cases = ((0.002, -0.002, 6.84e-3, 3.22e-3), (-0.002, 0.002, -4.14e-3, -0.37e-3),
             (0.002, 0.002, 0.60e-3, 0.70e-3))
    for d1, d2, fixed, flight in cases:
        true = dc.replace(p0.plant, l1=p0.plant.l1 + d1, l2=p0.plant.l2 + d2)
        q = initial_configuration(1.2, true)
        L = -line_gap(q[0], q[0] + q[1], p0.plant.l1, p0.plant.l2, 0.0)[0]
        base = p0.with_(true_plant=true, imu=dc.replace(p0.imu, noise=False))
        still = base.with_(estimator=dc.replace(base.estimator, estimate_misalignment=False))
        runs = [run_swing(q, seed=0).summary for q in (
            still, base, with_hardware(base, "line-sensor").with_(
                line_sensor=LineSensorParams(fitted=True, range=0.2, sigma=0.0)))]
        assert [r["outcome"] for r in runs] == ["captured"] * 3
        errors = [r["landing_height_error_m"] for r in runs]
        assert errors[0] == pytest.approx(fixed, abs=0.02e-3)
        assert errors[1] == pytest.approx(flight, abs=0.02e-3)
        if abs(L) > 1e-3:   # the start's error, grown, and the in-flight estimate's share of it
            assert abs(errors[0]) > abs(L) and math.copysign(1, errors[0]) == math.copysign(1, L)
            assert abs(errors[1]) < abs(errors[0])
        assert abs(errors[2]) < 0.15e-3


def test_the_standstill_calibration_measures_the_sensors_offset_on_the_line():
    """Before the swing the free gripper holds the line (gap 0): the mean of
    its 500 readings is the offset, to ``sigma / sqrt(500)``; the IMUs'
    calibration is unchanged by it."""
    import dataclasses as dc

    from bplir_drake.diagrams.swing import standstill_calibration
    from bplir_drake.diagrams.swing_setup import swing_geometry
    from bplir_drake.systems.line_sensor import standstill_readings

    p = with_hardware(preset(), "line-sensor")
    p = p.with_(line_sensor=dc.replace(p.line_sensor, offset=0.0008, sigma=0.002))
    q0 = swing_geometry(p)[0]
    cal = standstill_calibration(p, q0, seed=4)
    readings = standstill_readings(p.line_sensor, 4, 500)
    assert cal.line_offset == pytest.approx(np.mean(readings), abs=1e-15)
    assert cal.line_offset == pytest.approx(0.0008, abs=4 * 0.002 / math.sqrt(500))
    assert cal.summary()["line_sensor_offset_m"] == cal.line_offset
    without = standstill_calibration(p.with_(line_sensor=dc.replace(p.line_sensor, fitted=False)),
                                     q0, seed=4)
    assert without.line_offset == 0.0
    assert (without.bias, without.misalign) == (cal.bias, cal.misalign)


def test_a_calibrated_offset_does_not_move_the_landing():
    """A 5 mm mounting offset, calibrated on the line before the swing:
    the landing height error stays that of no offset (noise-free sensors,
    default swing, seed 0: measured -0.01 mm both); uncalibrated (no
    standstill window) the estimate lands 5.1 mm lower (-5.09 mm)."""
    import dataclasses as dc

    from bplir_drake.analysis.swing.swing_runner import run_swing

    p = with_hardware(preset(), "line-sensor")
    p = p.with_(imu=dc.replace(p.imu, noise=False),
                line_sensor=dc.replace(p.line_sensor, sigma=0.0, offset=0.005))
    zero = p.with_(line_sensor=dc.replace(p.line_sensor, offset=0.0))
    raw = p.with_(estimator=dc.replace(p.estimator, standstill_samples=0))
    e = {name: run_swing(q, seed=0).summary["landing_height_error_m"]
         for name, q in (("offset", p), ("zero", zero), ("raw", raw))}
    assert e["offset"] == pytest.approx(e["zero"], abs=1e-5)
    assert e["zero"] == pytest.approx(-0.014e-3, abs=0.02e-3)
    assert e["raw"] - e["zero"] == pytest.approx(-0.005, abs=0.5e-3)


def test_the_presets_and_the_swapped_robot_choose_their_sensing():
    """The default robot is the dissertation's (IMUs alone, the landing aimed
    for them); the line sensor is a named hardware option that brings its
    landing aim; a traversal's swapped robot reads its own jaw's sensor and
    lands as the robot does (it was left with its IMUs alone: 93 of 100
    traversals of the flat line at 30 V passed on root seed 223, 99 with
    the sensor)."""
    from moves import traverse_swing
    from bplir_drake.params import IMU_ONLY_TUNING, LINE_SENSOR_OPTION

    p = preset()
    assert not p.line_sensor.fitted and p.motor.supply_voltage == 30.0
    assert {k: getattr(p.landing, k) for k in IMU_ONLY_TUNING} == IMU_ONLY_TUNING
    assert not preset("lab").line_sensor.fitted
    s = with_hardware(p, "line-sensor")
    assert s.line_sensor.fitted
    assert (s.line_sensor.range, s.landing.shoot_height, s.landing.shoot_min_time,
            s.landing.lift_law, s.landing.shoot_lift_min_time) == tuple(LINE_SENSOR_OPTION.values())
    assert not s.with_controller("cpfl-qft").line_sensor.fitted
    assert s.with_controller("plan").line_sensor.fitted
    assert imu_only(s) == p
    assert with_hardware(p, "48v").motor.supply_voltage == 48.0
    with pytest.raises(ParameterError, match="unknown hardware option 'solar'"):
        with_hardware(p, "solar")
    assert traverse_swing(s, 1, 1.2, 0.0).line_sensor.fitted
    swapped = traverse_swing(s, 2, 1.2, 0.0)
    assert swapped.line_sensor == s.line_sensor
    assert swapped.landing == traverse_swing(s, 1, 1.2, 0.0).landing
