"""The MultibodyPlant against the corrected closed form (4.6)-(4.8), kinematics."""
import math

import numpy as np
import pytest

from bplir_drake.params import ParameterError, PlantParams
from bplir_drake.systems import plant as K


def test_mass_bias_gravity_match_closed_form_at_100_states(params):
    p = params.plant
    pl = K.make_plant(p)
    ctx = pl.CreateDefaultContext()
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(100):
        q = rng.uniform(-math.pi, math.pi, 2)
        v = rng.uniform(-6, 6, 2)
        M, Cv, g = K.drake_manipulator_terms(pl, ctx, q, v)
        worst = max(worst, np.abs(M - K.mass_matrix(q, p)).max(),
                    np.abs(Cv - K.bias_term(q, v, p)).max(),
                    np.abs(Cv - K.coriolis_matrix(q, v, p) @ v).max(),
                    np.abs(g - K.gravity_vector(q, p)).max())
    assert worst < 1e-9


def test_printed_mass_matrix_is_not_symmetric_but_plant_is(params):
    p = params.plant
    q = [0.3, 1.1]
    M = K.mass_matrix(q, p)
    printed_m21 = p.I2 + p.m2 * p.lc2 ** 2 + p.m2 * p.l1 * p.lc2  # (4.6), no c2
    assert M[1, 0] == pytest.approx(M[0, 1])
    assert abs(printed_m21 - M[1, 0]) > 0.1


def test_skew_symmetry_of_mdot_minus_2c(params):
    """(7.12): qd^T (Mdot - 2C) qd = 0, the property behind (7.13)."""
    p = params.plant
    rng = np.random.default_rng(2)
    for _ in range(20):
        q, v = rng.uniform(-3, 3, 2), rng.uniform(-5, 5, 2)
        dq = 1e-6
        Mdot = (K.mass_matrix(q + dq * v, p) - K.mass_matrix(q - dq * v, p)) / (2 * dq)
        assert v @ (Mdot - 2 * K.coriolis_matrix(q, v, p)) @ v == pytest.approx(0, abs=1e-6)


def test_initial_configuration_for_default_spacing(params):
    q0 = K.initial_configuration(1.2, params.plant)
    np.testing.assert_allclose(q0, [-0.334, -1.997], atol=1e-3)
    np.testing.assert_allclose(K.gripper_position(q0, params.plant.l1, params.plant.l2),
                               [-1.2, 0.0], atol=1e-12)
    # elbow hangs below the line
    assert K.elbow_position(q0, params.plant.l1)[1] < 0
    qT = K.target_configuration(1.2, params.plant)
    np.testing.assert_allclose(qT, -q0)


def test_inclined_start_lies_on_the_inclined_line(params):
    p = params.plant
    a = math.radians(20)
    q0 = K.initial_configuration(1.2, p, a)
    qT = K.target_configuration(1.2, p, a)
    np.testing.assert_allclose(K.gripper_position(q0, p.l1, p.l2),
                               [-1.2 * math.cos(a), -1.2 * math.sin(a)], atol=1e-12)
    np.testing.assert_allclose(K.gripper_position(qT, p.l1, p.l2),
                               [1.2 * math.cos(a), 1.2 * math.sin(a)], atol=1e-12)


@pytest.mark.parametrize("D", [0.2, 2.2, 3.0, -1.0])
def test_unreachable_grip_spacing(params, D):
    with pytest.raises(ParameterError, match="grip_spacing .* out of reach.*allowed"):
        K.initial_configuration(D, params.plant)


def test_absolute_relative_round_trip():
    x = np.array([0.3, -1.2, 0.5, 2.0])
    th = K.absolute_from_relative(x)
    np.testing.assert_allclose(th, [0.3, -0.9, 0.5, 2.5])
    np.testing.assert_allclose(K.relative_from_absolute(th), x)


def test_gripper_velocity_is_derivative_of_position(params):
    p = params.plant
    q, v, h = np.array([0.4, -0.7]), np.array([1.3, -2.1]), 1e-6
    num = (K.gripper_position(q + h * v, p.l1, p.l2)
           - K.gripper_position(q - h * v, p.l1, p.l2)) / (2 * h)
    np.testing.assert_allclose(K.gripper_velocity(q, v, p.l1, p.l2), num, atol=1e-8)


def test_no_effort_limit_on_elbow(params):
    pl = K.make_plant(params.plant)
    act = pl.get_joint_actuator(pl.GetJointActuatorIndices()[0])
    assert math.isinf(act.effort_limit())


def test_forward_dynamics_matches_plant(params):
    p = PlantParams()
    pl = K.make_plant(p)
    ctx = pl.CreateDefaultContext()
    q, v = np.array([0.2, -1.0]), np.array([0.5, 1.5])
    pl.SetPositions(ctx, q)
    pl.SetVelocities(ctx, v)
    pl.get_actuation_input_port().FixValue(ctx, [3.0])
    xd = pl.EvalTimeDerivatives(ctx).CopyToVector()
    np.testing.assert_allclose(K.forward_dynamics(q, v, 3.0, [0, 0], p), xd[2:], atol=1e-10)


#: a robot whose centres of mass sit off the links' axes (an AcroMonk-sized one)
OFF_AXIS = PlantParams(m1=1.16, m2=0.63, l1=0.3147, l2=0.3147, lc1=0.23, lc2=0.10,
                       oc1=0.021, oc2=-0.012, I1=0.0012, I2=0.0008)


def test_off_axis_centres_of_mass_match_the_plant():
    """With the centres of mass off the links' axes the closed form, the
    predictor's folded constants, their compiled form and the landing's
    model are the MultibodyPlant's dynamics."""
    from bplir_drake.params import FrictionParams
    from bplir_drake.systems.predictor import nominal_rates

    from bplir_drake.systems import nominal_kernel
    from bplir_drake.systems.landing import ApexShot, Landing

    p, fr = OFF_AXIS, FrictionParams(enabled=False)
    pl = K.make_plant(p)
    ctx = pl.CreateDefaultContext()
    rates = nominal_rates(p, fr)
    shot = ApexShot(Landing(p, 0.0, *[0.0] * 7), fr, 0.0, 0.0, 0.1, 0.0)
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(50):
        q, v = rng.uniform(-math.pi, math.pi, 2), rng.uniform(-6, 6, 2)
        M, Cv, g = K.drake_manipulator_terms(pl, ctx, q, v)
        qdd = np.linalg.solve(M, np.array([0.0, 0.4]) - Cv - g)
        # link 1's acceleration the landing's shot predicts for the elbow's
        link1 = nominal_kernel.link1_accel(shot.constants, *q, *v, qdd[1])
        compiled = nominal_kernel.rates(shot.constants, *q, *v, 0.4)[2:]
        worst = max(worst, np.abs(M - K.mass_matrix(q, p)).max(),
                    np.abs(Cv - K.bias_term(q, v, p)).max(),
                    np.abs(g - K.gravity_vector(q, p)).max(),
                    np.abs(np.array(rates(*q, *v, 0.4)[2:]) - qdd).max(), abs(link1 - qdd[0]),
                    np.abs(np.array(compiled) - qdd).max())
        # the potential is the gravity's integral: dV/dq = g(q)
        h = 1e-6
        dV = [(K.potential_energy(q + h * e, p) - K.potential_energy(q - h * e, p)) / (2 * h)
              for e in np.eye(2)]
        assert np.allclose(dV, g, atol=1e-6)
    assert worst < 1e-9
    # an on-axis robot's offsets change nothing: the old formulas to the last bit
    on = PlantParams()
    q, v = np.array([0.4, -1.2]), np.array([1.5, -2.0])
    s1, s12 = math.sin(q[0]), math.sin(q[0] + q[1])
    assert K.gravity_vector(q, on)[0] == (on.m1 * on.g * on.lc1 * s1
                                          + on.m2 * on.g * (on.l1 * s1 + on.lc2 * s12))


def test_swapped_off_axis_robot_has_the_same_centres_of_mass():
    """Seen from the other gripper, each link's centre of mass stays where it
    is: the swapped plant's offsets change sign with the link's direction."""
    from bplir_drake.params.model import swapped_plant

    p = OFF_AXIS
    ps = swapped_plant(p)
    q = np.array([0.7, -2.1])
    grip = K.gripper_position(q, p.l1, p.l2)
    own = K.link_centres_of_mass(q, p)
    seen = K.link_centres_of_mass(K.swapped_state(q), ps) + grip
    assert np.allclose(seen[::-1], own, atol=1e-12)
    assert swapped_plant(ps) == p


def test_the_planners_closed_form_is_the_multibody_plants_dynamics():
    """The planner's ``SymbolicVectorSystem`` and the ``MultibodyPlant`` with
    its friction system give the same derivatives and the same Jacobians
    (AutoDiffXd) at random states and torques, on the default robot held by
    either gripper, on one whose centres of mass sit off the links' axes and
    with air drag on both links."""
    import dataclasses

    import numpy as np
    from pydrake.autodiffutils import ExtractGradient, ExtractValue, InitializeAutoDiff

    from bplir_drake.params import BplirParams, swapped
    from bplir_drake.planning.swing_plan import plan_friction
    from bplir_drake.systems.frictional_plant import frictional_plant
    from bplir_drake.systems.symbolic_plant import symbolic_plant

    p = BplirParams()
    off = dataclasses.replace(p.plant, oc1=0.03, oc2=-0.05)
    drag = dataclasses.replace(p.friction, area1=0.02, area2=0.03)   # qd |qd| air drag
    rng = np.random.default_rng(7)
    for plant, friction in ((p.plant, p.friction), (swapped(p).plant, swapped(p).friction),
                            (off, p.friction), (p.plant, drag)):
        friction = plan_friction(friction)
        pair = [s.ToAutoDiffXd() for s in (frictional_plant(plant, friction),
                                           symbolic_plant(plant, friction))]
        for _ in range(5):
            z = InitializeAutoDiff(np.r_[rng.uniform(-3, 3, 2), rng.uniform(-6, 6, 2),
                                         rng.uniform(-20, 20)])
            out = []
            for s in pair:
                c = s.CreateDefaultContext()
                c.SetContinuousState(z[:4, 0])
                s.get_input_port(0).FixValue(c, z[4:, 0])
                d = s.EvalTimeDerivatives(c).CopyToVector()
                out.append((ExtractValue(d).ravel(), ExtractGradient(d)))
            assert np.allclose(out[0][0], out[1][0], rtol=1e-10, atol=1e-10)
            assert np.allclose(out[0][1], out[1][1], rtol=1e-9, atol=1e-9)
            assert np.abs(out[0][0][2:]).max() > 1.0   # the accelerations are not trivial
