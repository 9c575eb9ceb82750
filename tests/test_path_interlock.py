"""Path generator (chapter 7) and gripper interlock, as pure functions and systems."""
import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource

from bplir_drake.params import PlantParams, ScenarioParams
from bplir_drake.systems.gripper import OUTCOMES, GripperInterlock, LineGeometry, line_metrics
from bplir_drake.systems.path import (PathGeometry, path_q2, predict_rate_squared,
                                      q2_line_seeking)
from bplir_drake.systems.path_generator import PathGenerator
from bplir_drake.systems.plant import gripper_position, initial_configuration
from bplir_drake.params import imu_only


@pytest.mark.parametrize("alpha_deg", [0.0, 20.0, -20.0])
def test_line_seeking_puts_gripper_on_the_inclined_line(params, alpha_deg):
    p = params.plant
    a = math.radians(alpha_deg)
    for q1 in np.linspace(a - 0.3, a + 0.5, 9):
        q2 = q2_line_seeking(q1 - a, p.l1, p.l2)
        x, y = gripper_position([q1, q2], p.l1, p.l2)
        assert -x * math.sin(a) + y * math.cos(a) == pytest.approx(0.0, abs=1e-12)


def test_printed_7_27_misses_the_inclined_line(params):
    """(7.27) as printed (l1 for both links, q_line inside the arccos)."""
    p = params.plant
    a = math.radians(20)
    q1 = 0.6
    q2 = math.acos(-(p.l1 / p.l2) * math.cos(q1) + a) - q1 - a
    x, y = gripper_position([q1, q2], p.l1, p.l2)
    assert abs(-x * math.sin(a) + y * math.cos(a)) > 0.05


def test_rts_path_endpoints_and_blend_end(params):
    g = PathGeometry.from_scenario(params.plant, 1.2, 0.0)
    q0 = initial_configuration(1.2, params.plant)
    assert path_q2(-g.s_f, g.s_f, g, 2.0) == pytest.approx(q0[1])          # starts at q0 (7.1)
    assert path_q2(-g.s_f, g.s_f, g, 2.0, lam=1.5) == pytest.approx(q0[1])  # pumping keeps it
    assert path_q2(g.s_f, g.s_f, g, 2.0) == pytest.approx(-q0[1])          # mirror target
    for s_e in (0.8 * g.s_f, 1.2 * g.s_f):                                  # re-targeted end
        assert path_q2(s_e, s_e, g, 2.0) == pytest.approx(q2_line_seeking(s_e, g.l1, g.l2))
    h = 1e-7   # continuous through the vertical (both sides -> 0)
    assert abs(path_q2(h, g.s_f, g, 2.0)) < 10 * g.k_f * h
    assert abs(path_q2(-h, g.s_f, g, 2.0)) < 10 * g.k_f * h


def test_reduced_dynamics_prediction_matches_constrained_simulation(params):
    """The predictor's q1'^2 on the path equals a simulation of the plant
    held exactly on the virtual constraint (frictionless)."""
    from scipy.integrate import solve_ivp

    from bplir_drake.systems.path import path_derivatives
    from bplir_drake.systems.plant import bias_term, gravity_vector, mass_matrix

    p = params.plant
    g = PathGeometry.from_scenario(p, 1.2, 0.0)
    s_e = 0.3   # the predictor integrates up to the blend end of the path

    def rhs(t, x):
        s, w = x
        _, d1, d2 = path_derivatives(s, s_e, g, 2.0)
        q = [s, path_q2(s, s_e, g, 2.0)]
        M = mass_matrix(q, p)
        h = bias_term(q, [w, d1 * w], p)
        gv = gravity_vector(q, p)
        return [w, -(M[0, 1] * d2 * w * w + h[0] + gv[0]) / (M[0, 0] + M[0, 1] * d1)]

    s0, w0 = -0.1, 0.6
    ev = lambda t, x: x[0] - (s_e - 1e-9)   # noqa: E731
    ev.terminal = True
    sol = solve_ivp(rhs, (0, 2), [s0, w0], events=ev, rtol=1e-10, atol=1e-12)
    w_sim = sol.y_events[0][0][1]
    Y = predict_rate_squared(s0, w0, s_e, g, 2.0, 1.0, p, 0.0, step=0.002)
    assert Y == pytest.approx(w_sim ** 2, rel=1e-4)


def test_path_generator_reads_state_not_clock(params):
    g = PathGeometry.from_scenario(params.plant, 1.2, 0.0)
    pg = PathGenerator(params.plant, params.path, g, 0.01)
    ctx = pg.CreateDefaultContext()
    pg.get_input_port(0).FixValue(ctx, [-0.2, 0.0, 0.5, 3.0])
    r1 = pg.GetOutputPort("reference").Eval(ctx)[0]
    ctx.SetTime(7.3)
    assert pg.GetOutputPort("reference").Eval(ctx)[0] == r1
    lead = params.path.lead_time
    assert r1 == pytest.approx(path_q2(-0.2 + 0.5 * lead, g.s_f, g, 2.0))
    # the AutoDiff copy gives the same reference (for linearising a loop with it)
    from pydrake.autodiffutils import InitializeAutoDiff

    ad = pg.ToAutoDiffXd()
    actx = ad.CreateDefaultContext()
    ad.get_input_port(0).FixValue(actx, InitializeAutoDiff(np.array([-0.2, 0.0, 0.5, 3.0]))[:, 0])
    assert ad.GetOutputPort("reference").Eval(actx)[0].value() == pytest.approx(r1, rel=1e-12)


def _interlock_outcome(x, *, tripped=0.0, t_end=0.05):
    sc, pp = ScenarioParams(), PlantParams()
    geo = LineGeometry(pp.l1, pp.l2, 0.0, sc.grip_spacing)
    b = DiagramBuilder()
    lock = b.AddSystem(GripperInterlock(geo, sc))
    for name, val in (("state", x), ("tripped", [tripped]), ("estimate", x), ("torque", [0.0])):
        src = b.AddSystem(ConstantVectorSource(np.asarray(val, dtype=float)))
        b.Connect(src.get_output_port(0), lock.GetInputPort(name))
    d = b.Build()
    sim = Simulator(d)
    sim.AdvanceTo(t_end)
    return lock.status(sim.get_context())


def test_interlock_outcomes():
    qT = -initial_configuration(1.2, PlantParams())
    st = _interlock_outcome([*qT, 0.0, 0.0])
    assert st["outcome"] == "captured" and st["fixed_gripper_open"]
    st = _interlock_outcome([*qT, 1.0, 0.0])                   # 1 rad/s of link 1: ~1.2 m/s
    assert st["outcome"] == "crash" and not st["fixed_gripper_open"]
    st = _interlock_outcome([0.0, 0.0, 0.0, 0.0], t_end=3.1)  # hanging, never arrives
    assert st["outcome"] == "timeout" and not st["fixed_gripper_open"]
    st = _interlock_outcome([0.0, 0.0, 0.0, 0.0], tripped=1.0)
    assert st["outcome"] == "fault" and not st["fixed_gripper_open"]
    # the start pose is on the line but before the vertical: no arrival there
    q0 = initial_configuration(1.2, PlantParams())
    st = _interlock_outcome([*q0, 0.0, 0.0], t_end=0.2)
    assert st["outcome"] == "swinging"
    assert set(OUTCOMES) == {"swinging", "captured", "crash", "timeout", "fault"}


def test_line_metrics(params):
    p = params.plant
    qT = -initial_configuration(1.2, p)
    geo = LineGeometry(p.l1, p.l2, 0.0, 1.2)
    normal, along, travel, speed = line_metrics(np.array([*qT, 0.0, 0.0]), geo)
    assert normal == pytest.approx(0.0, abs=1e-12)
    assert along == pytest.approx(1.2)
    assert travel == pytest.approx(2.4)
    assert speed == 0.0


def test_latch_lift_rescues_a_swing_that_stops_just_short_of_the_line():
    """Sample 3 of the default study (root seed 0; of its first twelve
    samples the one that crashes without the lift), adaptive path, the
    trapezoid filter the latch was built with: aimed at the line itself the
    latched path turns with the gripper just outside the band and meets the
    line at 0.62 m/s; aimed 10 mm above it (``latch_lift``, a margin for the
    elbow's tracking error) the swing is captured at 0.26 m/s."""
    import dataclasses as dc

    from bplir_drake.analysis import montecarlo as mc
    from bplir_drake.analysis.swing.swing_runner import run_swing
    from bplir_drake.params import TRAPEZOID_TUNING

    p, seed, _ = mc.sample_params(mc.Study(samples=5, seed=0), 3)
    p = imu_only(p)   # the robot it was built for: no line sensor
    p = p.with_(path=dc.replace(p.path, mode="adaptive"),   # the latch is the adaptive path's
                estimator=dc.replace(p.estimator, **TRAPEZOID_TUNING))
    assert p.path.latch_lift == 0.01
    old = run_swing(p.with_(path=dc.replace(p.path, latch_lift=0.0)), seed=seed).summary
    assert old["outcome"] == "crash" and old["capture_speed_mps"] > 0.6
    assert old["swing_time_s"] > 1.45  # after falling back, not on the first approach
    new = run_swing(p, seed=seed).summary
    assert new["outcome"] == "captured" and new["capture_speed_mps"] < 0.5
