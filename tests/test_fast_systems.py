"""The systems of the fast closed loop against their references: the C++
friction and motor against the pure laws, the closed-form EKF Jacobians
against AutoDiff, the vectorised path predictor against an exact solve, the
tick schedule against the offline filter, the interpolated interlock against
a closed-form arrival, and the fast swing against an accurate reference."""
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from bplir_drake.params import (EstimatorParams, FrictionParams, GripperParams, MotorParams,
                                ScenarioParams,
                                preset)
from bplir_drake.systems import ekf as E
from bplir_drake.systems import ekf_model as EM
from bplir_drake.systems.friction import (JointFriction, friction_system, friction_torques,
                                          set_friction)
from bplir_drake.systems.gripper import LineGeometry, first_arrival, line_metrics
from bplir_drake.systems.motor import MotorDriver, current_command
from bplir_drake.params import with_hardware
from bplir_drake.systems.path import (PathGeometry, PathShape, ReducedDynamics, path_derivatives,
                                      path_q2, predict_rate_squared)


@pytest.mark.parametrize("in_context", [False, True])
def test_symbolic_friction_equals_the_templated_law(in_context):
    p = FrictionParams(area1=0.01, area2=0.02)
    fast = friction_system(p, in_context=in_context)
    cf = fast.CreateDefaultContext()
    rng = np.random.default_rng(0)
    laws = [p]
    if in_context:  # other coefficients set in the context, same b and drag
        laws.append(p.with_factors((1.2, 0.8, 1.15, 0.9)))
    for law in laws:
        if in_context:
            set_friction(fast, cf, law)
        ref = JointFriction(law)
        cr = ref.CreateDefaultContext()
        for _ in range(100):
            x = rng.normal(size=4) * [1.0, 1.0, 5.0, 0.05]
            fast.get_input_port(0).FixValue(cf, x)
            ref.get_input_port(0).FixValue(cr, x)
            np.testing.assert_allclose(fast.get_output_port(0).Eval(cf),
                                       ref.get_output_port(0).Eval(cr), rtol=0, atol=1e-12)
            # its state integrates the power friction dissipates
            f = friction_torques(x[2:4], law)
            assert fast.EvalTimeDerivatives(cf).CopyToVector()[0] == pytest.approx(
                f[0] * x[2] + f[1] * x[3], rel=1e-12, abs=1e-15)


def test_driver_target_current_is_the_current_command_law():
    """The motor's current loop (C++ symbolic) settles on the current of
    current_command, exactly: its rate is zero there, for every command and
    trip state."""
    p = MotorParams()
    m = MotorDriver(p)
    ctx = m.CreateDefaultContext()
    m.GetInputPort("state").FixValue(ctx, np.zeros(4))
    elec = m.GetSubsystemByName("electrics")
    ectx = elec.GetMyMutableContextFromRoot(ctx)
    for tripped in (False, True):
        m.set_interlock_state(ctx, 1.0, tripped)
        assert m.interlock_state(ctx) == (1.0, tripped)
        for tau in np.linspace(-30.0, 30.0, 241):
            m.GetInputPort("torque_command").FixValue(ctx, [tau])
            i = current_command(tau, p, tripped)
            ectx.SetContinuousState([i / p.i_peak, 0.0, 0.0, 0.0, 0.0])
            assert elec.EvalTimeDerivatives(ectx).CopyToVector()[0] == 0.0
            assert m.GetOutputPort("current").Eval(ctx)[0] == pytest.approx(i, rel=1e-15)
        assert m.GetOutputPort("available").Eval(ctx)[0] == min(
            p.torque_limit, p.torque_per_amp * (p.i_cont if tripped else p.i_peak))


def test_current_loop_is_first_order_with_the_time_constant():
    p = MotorParams()
    b = DiagramBuilder()
    m = b.AddSystem(MotorDriver(p))
    b.Connect(b.AddSystem(ConstantVectorSource([5.0])).get_output_port(0),
              m.GetInputPort("torque_command"))
    b.Connect(b.AddSystem(ConstantVectorSource([0.0, 0.0, 0.0, 2.0])).get_output_port(0),
              m.GetInputPort("state"))
    log = {n: LogVectorOutput(m.GetOutputPort(n), b, 0.001) for n in ("current", "power")}
    sim = Simulator(b.Build())
    sim.get_mutable_integrator().set_target_accuracy(1e-9)
    sim.AdvanceTo(0.03)
    lg = log["current"].FindLog(sim.get_context())
    t, i = lg.sample_times(), lg.data()[0]
    i_target = 5.0 / p.torque_per_amp
    np.testing.assert_allclose(i, i_target * (1.0 - np.exp(-t / p.tau_current)), atol=1e-6)
    power = log["power"].FindLog(sim.get_context()).data()[0]
    np.testing.assert_allclose(power, p.torque_per_amp * i * 2.0, rtol=1e-12)


@pytest.mark.parametrize("est", [EstimatorParams().chapter5(), EstimatorParams(),
                                 EstimatorParams(estimate_bias=False).chapter5()])
def test_closed_form_ekf_jacobians_equal_autodiff(est):
    rng = np.random.default_rng(1)
    n = 6 if est.estimate_bias else 4
    for _ in range(50):
        x, u = rng.normal(size=n), 3.0 * rng.normal(size=2)
        v, A, W = EM.jacobians(EM.discrete_f, x, u, est)
        v2, A2, W2 = E.discrete_f_jacobians(x, u, est)
        h, H, _ = EM.jacobians(EM.kinematic_h, x, u, est)
        h2, H2 = E.kinematic_h_jacobian(x, u, est)
        for a, b in ((v, v2), (A, A2), (W, W2), (h, h2), (H, H2)):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)


def test_path_shape_matches_the_path_and_its_finite_differences():
    p = preset().plant
    g = PathGeometry.from_scenario(p, 1.2, 0.0)
    for lam in (1.0, 1.4):
        for s_e in (0.3, g.s_f, 1.3 * g.s_f):
            shape = PathShape(s_e, g, 2.0, lam)
            for s in np.linspace(-g.s_f, 1.4 * s_e, 57):
                if abs(s) < 1e-3 or abs(s - s_e) < 1e-3:
                    continue  # the finite differences straddle a branch point there
                ref = path_derivatives(float(s), s_e, g, 2.0, lam)
                got = shape.derivs(float(s))
                assert shape.value(float(s)) == pytest.approx(path_q2(float(s), s_e, g, 2.0, lam),
                                                              abs=1e-12)
                np.testing.assert_allclose(got, ref, rtol=1e-5, atol=2e-4)


def _exact_prediction(s, qd1, s_e, g, p, fv1):
    """q1'^2 at s_e by an adaptive solve at 1e-12, each branch with its own
    one-sided limits at the vertical."""
    from scipy.integrate import solve_ivp

    shape = PathShape(s_e, g, 2.0)
    dyn = ReducedDynamics(shape, g.alpha, p, fv1)

    def f(x, Y, branch):
        P, Q, R = (float(np.ravel(c)[0]) for c in dyn.coefficients(np.array([x]), branch))
        return [P * Y[0] + Q + R * math.sqrt(max(Y[0], 0.0))]

    Y = qd1 * qd1
    if s < 0.0:
        Y = solve_ivp(lambda x, y: f(min(x, 0.0), y, shape.rts), (s, 0.0), [Y],
                      rtol=1e-12, atol=1e-12).y[0, -1]
    return solve_ivp(lambda x, y: f(max(x, 1e-15), y, shape.blend), (max(s, 0.0), s_e - 1e-9),
                     [Y], rtol=1e-12, atol=1e-12).y[0, -1]


@pytest.mark.slow
def test_predictor_converges_to_the_exact_reduced_dynamics():
    """At the default step (0.005 rad) the RK4 predictor is within 2e-4
    (rad/s)^2 of an exact solve, on states like those of a swing.  The
    predictor before the speed work accumulated s in floats; when the sum
    crossed the vertical by an ulp it used the blend's curvature (53 rad^-1
    and more) on the first half, and so was up to 0.36 (rad/s)^2 off (10 %)
    in 100 of the 547 predictions of three default swings."""
    p = preset().plant
    g = PathGeometry.from_scenario(p, 1.2, 0.0)
    rng = np.random.default_rng(3)
    for _ in range(12):
        s, s_e = rng.uniform(-0.25, 0.1), rng.uniform(0.3, 0.75)
        qd1, fv1 = rng.uniform(0.4, 0.7), rng.uniform(0.0, 0.4)
        Y = predict_rate_squared(s, qd1, s_e, g, 2.0, 1.0, p, fv1, step=0.005)
        assert Y == pytest.approx(_exact_prediction(s, qd1, s_e, g, p, fv1), abs=2e-4)


def test_tick_schedule_estimates_from_the_sample_of_the_same_tick():
    """The filter in the diagram and the offline filter over its logged IMU
    samples agree to rounding: each tick's estimate uses that tick's sample
    (no period of delay), and every tick is processed exactly once."""
    from bplir_drake.diagrams import build_sensor_swing
    from bplir_drake.estimation import estimate
    from bplir_drake.simulate import logs, make_simulator, run

    params = preset()
    x0 = np.array([0.4, 0.4, 0.0, 0.0])
    built = build_sensor_swing(params, x0_estimate=x0, elbow_torque=((0.0, 0.3), (2.0, -1.0)))
    sim = make_simulator(built, (0.4, 0.0))
    run(sim, 1.0)
    lg = logs(built, sim)
    imu, est = lg["imu"], lg["estimate"]
    np.testing.assert_allclose(imu.t, np.arange(len(imu.t)) * params.imu.period, atol=1e-12)
    assert len(est.t) == len(imu.t) >= 99
    offline = estimate(imu.t, imu.data, params.estimator.chapter5(), x0).x
    np.testing.assert_allclose(est.data, offline, rtol=0, atol=1e-10)


def test_interlock_locates_the_arrival_between_ticks_exactly():
    """Link 1 turning at a constant rate with the elbow fixed: the state is
    linear in time, so the Hermite interpolant is exact and the arrival time
    and speed are those of the closed form, whatever the tick."""
    pp = preset().plant
    sc = ScenarioParams()
    geo = LineGeometry(pp.l1, pp.l2, 0.0, sc.grip_spacing)
    qT = -np.array([-0.33378987, -1.99837957])  # near the mirror target
    w = 0.25  # rad/s: 0.3 m/s at the gripper
    x_at = lambda t: np.array([qT[0] - 0.05 + w * t, qT[1], w, 0.0])  # noqa: E731
    # closed form: the first time the gripper is within 2 cm below the line
    from scipy.optimize import brentq

    t_exact = brentq(lambda t: line_metrics(x_at(t), geo)[0] + GripperParams().capture_distance,
                    0.0, 0.2)
    T = 0.01
    k = int(t_exact // T)
    s, xa, passed, normal, _ = first_arrival(x_at(k * T), x_at((k + 1) * T), T, geo, sc,
                                             True, line_metrics(x_at(k * T), geo)[0])
    assert passed and normal == pytest.approx(-GripperParams().capture_distance, abs=1e-9)
    assert k * T + s * T == pytest.approx(t_exact, abs=1e-9)
    assert line_metrics(xa, geo)[3] == pytest.approx(line_metrics(x_at(t_exact), geo)[3],
                                                     abs=1e-9)


@pytest.mark.slow
def test_fast_swing_matches_an_accurate_reference():
    """The default integrator (error-controlled RK3 at 1e-3): seeds 0-9
    all captured, each run ending at the tick after the interlock decided;
    against RK5 at 1e-10 on the same diagram the same outcome, a median
    capture-speed error within the 2e-3 m/s the speed work asks for and
    none beyond 5e-3 m/s (median 1.3e-3, largest 2.0e-3 measured)."""
    from bplir_drake.analysis.swing.swing_runner import SwingRunner

    params = preset()
    runner = SwingRunner()
    errors = []
    for seed in range(10):
        fast = runner.run(params, seed=seed)
        assert fast.summary["outcome"] == "captured", seed
        t_end = fast.logs["state"].t[-1]
        assert fast.summary["swing_time_s"] < t_end <= fast.summary["swing_time_s"] + 0.0101
        ref = runner.run(params, seed=seed, accuracy=1e-10, integrator="runge_kutta5")
        assert ref.summary["outcome"] == "captured", seed
        errors.append(abs(fast.summary["capture_speed_mps"] - ref.summary["capture_speed_mps"]))
    assert np.median(errors) <= 2e-3 and max(errors) <= 5e-3


def test_the_onboard_computer_is_its_parts_wired_one_by_one():
    """The robot's computer as one system (IMU sampler, EKF, delay
    identifier and predictor, plan tracker: systems.onboard) gives every
    log bit for bit as the parts wired one by one do: the default robot
    (its sample, filter step and prediction in the compiled front),
    a second seed of it through the same diagram (its sensors, calibration
    and friction set in the context), the line sensor's robot (its reading
    fused) and a sample of the realistic study."""
    from pathlib import Path

    from bplir_drake.analysis.montecarlo import load_study, sample_params
    from bplir_drake.analysis.swing.swing_runner import SwingRunner

    study = load_study(Path(__file__).resolve().parents[1] / "examples" / "study_realistic.toml")
    runs = [(preset(), 3), (preset(), 4), (with_hardware(preset(), "line-sensor"), 1),
            sample_params(study.with_(seed=5), 0)[:2]]
    fused, parts = SwingRunner(), SwingRunner(onboard=False)
    for p, seed in runs:
        a, b = fused.run(p, seed=seed), parts.run(p, seed=seed)
        assert fused.built.diagram.HasSubsystemNamed("onboard")
        computer = fused.built.systems["ekf"]
        assert (computer._front == computer._front_compiled) == (computer.line_port is None)
        assert parts.built.diagram.HasSubsystemNamed("ekf")
        assert a.summary["outcome"] == "captured"
        assert a.logs.keys() == b.logs.keys()
        for name in a.logs:
            assert np.array_equal(a.logs[name].t, b.logs[name].t), name
            assert np.array_equal(a.logs[name].data, b.logs[name].data, equal_nan=True), name
    assert (fused.builds, parts.builds) == (3, 3)   # the second seed reused the first's


def test_a_released_swing_diagram_is_freed_with_the_onboard_computers_parts():
    """Built.release lets a swing's diagram go: the diagram, its onboard
    computer and the parts it runs (systems outside the diagram) are all
    collected once the last reference is dropped (pydrake's reference
    cycles through C++ would keep them, about 1 MB a build)."""
    import gc
    import weakref

    from bplir_drake.analysis.swing.swing_runner import swing_diagram

    built = swing_diagram(preset(), seed=0)
    computer = built.systems["controller"]
    held = [weakref.ref(s) for s in (built.diagram, computer, computer.ekf, computer.tracker,
                                     computer.sampler, computer.predictor, computer.identifier)]
    del computer
    built.release()
    del built
    gc.collect()
    assert [ref() is None for ref in held] == [True] * len(held)


def test_the_quick_template_lookup_names_the_module_pydrakes_own_does():
    """systems.base.quick_template_scopes: a scalar-templated system class
    instantiated under it gets the same module for its ToScalarType
    methods as under pydrake's own lookup (inspect.stack), and pydrake's
    lookup is back afterwards."""
    from pydrake.common import cpp_template
    from pydrake.systems.framework import LeafSystem_
    from pydrake.systems.scalar_conversion import TemplateSystem

    from bplir_drake.systems.pysystem import quick_template_scopes

    def template(name):
        @TemplateSystem.define(name, T_list=(float,))
        def Empty_(T):
            class Impl(LeafSystem_[T]):
                def _construct(self, converter=None):
                    LeafSystem_[T].__init__(self, converter)

                def _construct_copy(self, other, converter=None):
                    Impl._construct(self, converter=converter)
            return Impl
        return Empty_

    own = template("OwnLookup_")[None]
    before = cpp_template._get_module_from_stack
    with quick_template_scopes():
        quick = template("QuickLookup_")[None]
    assert cpp_template._get_module_from_stack is before
    for method in ("ToScalarType", "ToScalarTypeMaybe"):
        assert getattr(quick, method)._scope is getattr(own, method)._scope
    assert own.ToScalarType._scope.__name__ == "pydrake.systems.scalar_conversion"
