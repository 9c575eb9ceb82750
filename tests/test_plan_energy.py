"""A plan's energy balance: the elbow's work less the friction's is the
robot's change of energy along a trajectory whose dynamics hold, and not
along one whose steps lend it energy."""
from __future__ import annotations

import numpy as np
import pytest

from bplir_drake.diagrams.open_loop import build_plant_with_friction
from bplir_drake.planning.swing_plan import SwingPlan, energy_balance, plan_friction
from bplir_drake.params import preset
from bplir_drake.systems.friction import friction_torques_along


def _simulated(params, duration=2.0, n=2001):
    """The nominal robot with the planner's friction, released from hanging
    tilted by 0.6 rad, its elbow driven by 3 sin(5 t) N m: a plan's samples."""
    from pydrake.all import Simulator, TrajectorySource, DiagramBuilder, PiecewisePolynomial

    friction = plan_friction(params.friction)
    built = build_plant_with_friction(params.with_(friction=friction), nominal=True)
    t = np.linspace(0.0, duration, n)
    tau = 3.0 * np.sin(5.0 * t)
    b = DiagramBuilder()
    plant = b.AddSystem(built.diagram)
    src = b.AddSystem(TrajectorySource(PiecewisePolynomial.CubicShapePreserving(
        t, tau[None, :], zero_end_point_derivatives=False)))
    b.Connect(src.get_output_port(), plant.get_input_port())
    diagram = b.Build()
    sim = Simulator(diagram)
    ctx = sim.get_mutable_context()
    sub = diagram.GetMutableSubsystemContext(plant, ctx)
    built.plant.SetPositionsAndVelocities(
        built.diagram.GetMutableSubsystemContext(built.plant, sub), [0.6, 0.3, 0.0, 0.0])
    sim.get_mutable_integrator().set_target_accuracy(1e-10)
    states = []
    for tk in t:
        sim.AdvanceTo(tk)
        states.append(plant.get_output_port().Eval(sub).copy())
    states = np.array(states)
    return SwingPlan(t, states, tau, friction_torques_along(states, friction), True, True,
                     "simulated", 0.0, 20.0, 220.0, 1e-4)


def test_a_trajectory_whose_dynamics_hold_balances_its_energy():
    """Simulated at 1e-10: the balance closes to 1e-5 of the energy exchanged;
    the same motion with no torque claimed leaves the elbow's work unaccounted."""
    params = preset()
    plan = _simulated(params)
    b = energy_balance(plan, params.plant)
    assert abs(b["work_J"]) > 1.0 and b["friction_J"] > 1.0
    assert b["residual_share"] < 1e-5
    free = SwingPlan(plan.times, plan.states, 0.0 * plan.torque, plan.friction, True, True,
                     "edited", 0.0, 20.0, 220.0, 1e-4)
    lent = energy_balance(free, params.plant)
    assert lent["residual_J"] == pytest.approx(b["work_J"], rel=1e-2)
    assert lent["residual_share"] == pytest.approx(abs(b["work_J"]) / b["friction_J"], rel=2e-2)
