"""Actuation-delay compensation: the state predicted over the delay.

With an actuation delay of ``D`` ticks, the command computed at tick ``k``
acts from ``t_{k+D}``; the commands that act until then are already known
(ticks ``k-D .. k-1``).  :class:`DelayPredictor` integrates the *nominal*
model (plant and friction, the controller's own) from the tick's estimate
over those ``D`` ticks with those commands, so the path generator and the
controller act on where the robot will be when their command arrives (a
predictor in the spirit of Smith's).  ``D`` is a parameter of the nominal
model (``controller.delay_compensation``); a real delay that differs leaves
the difference uncompensated.
"""
from __future__ import annotations

import numpy as np
from pydrake.systems.framework import LeafSystem

from ..params import FrictionParams, PlantParams
from .friction import friction_torques
from .plant import forward_dynamics
from .schedule import declare_store, declare_tick_result


def predict_state(x, commands, period: float, plant: PlantParams, friction: FrictionParams,
                  substeps: int = 2) -> np.ndarray:
    """The state (q1, q2, q1d, q2d) after ``len(commands)`` ticks of
    ``period`` from ``x``, each command (elbow torque, N m) held over its
    tick, on the nominal model (RK4, ``substeps`` per tick)."""
    x = np.array(x, dtype=float)

    def f(x, tau):
        qdd = forward_dynamics(x[:2], x[2:], tau, friction_torques(x[2:], friction), plant)
        return np.array([x[2], x[3], qdd[0], qdd[1]])

    h = period / substeps
    for tau in commands:
        for _ in range(substeps):
            k1 = f(x, tau)
            k2 = f(x + 0.5 * h * k1, tau)
            k3 = f(x + 0.5 * h * k2, tau)
            k4 = f(x + h * k3, tau)
            x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x


class DelayPredictor(LeafSystem):
    """Inputs ``estimate`` (q1, q2, q1d, q2d at tick k) and ``command`` (the
    controller's elbow torque of tick k); output ``predicted`` (the state
    ``steps`` ticks ahead, :func:`predict_state`).  Discrete state: the
    commands of the last ``steps`` ticks (oldest first), the command of tick
    k stored at ``t_{k+1}`` (:mod:`bplir_drake.systems.schedule`).  The
    output does not depend on ``command``, so the loop through the
    controller has no algebraic loop."""

    def __init__(self, plant: PlantParams, friction: FrictionParams, period: float, steps: int):
        super().__init__()
        if steps < 1:
            raise ValueError("DelayPredictor needs steps >= 1")
        self.plant_params, self.friction, self.period, self.steps = plant, friction, period, steps
        self.estimate_port = self.DeclareVectorInputPort("estimate", 4)
        self.command_port = self.DeclareVectorInputPort("command", 1)
        self._xd = self.DeclareDiscreteState(steps)
        self._prediction = declare_tick_result(
            self, self._predict, {self.xd_ticket(), self.estimate_port.ticket()})
        declare_store(self, period, self._store)
        self.predicted_port = self.DeclareVectorOutputPort(
            "predicted", 4, lambda context, out: out.SetFromVector(self._prediction.Eval(context)),
            {self._prediction.ticket()})

    def _predict(self, context):
        commands = context.get_discrete_state(self._xd).get_value()
        return predict_state(self.estimate_port.Eval(context), commands, self.period,
                             self.plant_params, self.friction)

    def _store(self, context, discrete_state):
        buf = context.get_discrete_state(self._xd).get_value()
        discrete_state.get_mutable_vector(self._xd).SetFromVector(
            np.concatenate([buf[1:], self.command_port.Eval(context)]))
