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

import math

import numpy as np

from .pysystem import PySystem
from ..params import FrictionParams, PlantParams
from . import nominal_kernel
from .kernels import read_only
from .schedule import declare_store, declare_tick_result


def nominal_rates(plant: PlantParams, friction: FrictionParams):
    """``f(q1, q2, q1d, q2d, tau) -> (q1d, q2d, q1dd, q2dd)``: the plant's
    closed form (:func:`~bplir_drake.systems.plant.forward_dynamics`) with
    the friction (4.11) (:func:`~bplir_drake.systems.friction.friction_torques`)
    on plain floats, its constants folded once: the readable form of the
    compiled model the predictor integrates
    (:func:`~bplir_drake.systems.nominal_kernel.rates`).  Tested against the
    numpy functions to rounding."""
    m1, m2, l1, rc1, rc2, g = plant.m1, plant.m2, plant.l1, plant.rc1, plant.rc2, plant.g
    a = plant.I2 + m2 * rc2 ** 2
    m11c = m1 * rc1 ** 2 + plant.I1 + m2 * l1 ** 2 + a
    k12 = m2 * l1 * rc2
    (g1c, p1), g12c, dc2 = plant.gravity_link1(), m2 * g * rc2, plant.dc2
    on = friction.enabled
    (d1, d2), cf = friction.drag_coefficients(), 2.0 / math.pi
    fv1, fc1, fv2, fc2, b = friction.fv1, friction.fc1, friction.fv2, friction.fc2, friction.b

    def f(q1, q2, v1, v2, tau):
        c2, s2 = math.cos(q2 + dc2), math.sin(q2 + dc2)
        s1, s12 = math.sin(q1 + p1), math.sin(q1 + q2 + dc2)
        m12 = a + k12 * c2
        m11 = m11c + 2.0 * k12 * c2
        h = k12 * s2
        r0 = h * (2.0 * v1 * v2 + v2 * v2) - (g1c * s1 + g12c * s12)
        r1 = tau - h * v1 * v1 - g12c * s12
        if on:
            r0 -= fv1 * v1 + fc1 * cf * math.atan(v1 / b) + d1 * v1 * abs(v1)
            r1 -= fv2 * v2 + fc2 * cf * math.atan(v2 / b) + d2 * v2 * abs(v2)
        det = m11 * a - m12 * m12
        return v1, v2, (a * r0 - m12 * r1) / det, (m11 * r1 - m12 * r0) / det

    return f


def predict_state(x, commands, period: float, plant: PlantParams, friction: FrictionParams,
                  substeps: int = 2, constants=None) -> np.ndarray:
    """The state (q1, q2, q1d, q2d) after ``len(commands)`` ticks of
    ``period`` from ``x``, each command (elbow torque, N m) held over its
    tick, on the nominal model (RK4, ``substeps`` per tick, compiled:
    :func:`~bplir_drake.systems.nominal_kernel.predict`; ``constants``: the
    model's :func:`~bplir_drake.systems.nominal_kernel.pack`, made from
    ``plant`` and ``friction`` when not given)."""
    c = nominal_kernel.pack(plant, friction) if constants is None else constants
    return nominal_kernel.predict(c, np.asarray(x, dtype=float),
                                  read_only(np.asarray(commands, dtype=float).ravel()), period,
                                  substeps)


class DelayPredictor(PySystem):
    """Inputs ``estimate`` (q1, q2, q1d, q2d at tick k) and ``command`` (the
    controller's elbow torque of tick k); output ``predicted`` (the state
    ``steps`` ticks ahead, :func:`predict_state`).  Discrete state: the
    commands of the last ``steps`` ticks (oldest first), the command of tick
    k stored at ``t_{k+1}`` (:mod:`bplir_drake.systems.schedule`).  The
    output does not depend on ``command``, so the loop through the
    controller has no algebraic loop.

    With ``adaptive`` the number of ticks comes from the input
    ``delay_steps`` (0 .. ``steps``; an identified delay,
    :class:`~bplir_drake.systems.delay_id.DelayIdentifier`): the prediction
    runs over the last that many commands (0: the estimate itself)."""

    def __init__(self, plant: PlantParams, friction: FrictionParams, period: float, steps: int,
                 adaptive: bool = False):
        super().__init__()
        if steps < 1:
            raise ValueError("DelayPredictor needs steps >= 1")
        self.plant_params, self.friction, self.period, self.steps = plant, friction, period, steps
        self._constants = nominal_kernel.pack(plant, friction)
        self.estimate_port = self.DeclareVectorInputPort("estimate", 4)
        self.command_port = self.DeclareVectorInputPort("command", 1)
        self.steps_port = self.DeclareVectorInputPort("delay_steps", 1) if adaptive else None
        self._xd = self.DeclareDiscreteState(steps)
        prerequisites = {self.xd_ticket(), self.estimate_port.ticket()}
        if adaptive:
            prerequisites.add(self.steps_port.ticket())
        self._prediction = declare_tick_result(self, self._predict, prerequisites)
        declare_store(self, period, self._store)
        self.predicted_port = self.DeclareVectorOutputPort(
            "predicted", 4, lambda context, out: out.SetFromVector(self._prediction.Eval(context)),
            {self._prediction.ticket()})

    def _predict(self, context):
        return self.prediction(context.get_discrete_state(self._xd).get_value(),
                               self.estimate_port.Eval(context),
                               self.steps_port.Eval(context)[0]
                               if self.steps_port is not None else None)

    def taken(self, steps=None) -> int:
        """How many of the stored commands (the last ones) a prediction
        takes: all of them, or with ``steps`` (adaptive: the identified
        delay in ticks) that many."""
        if steps is None:
            return self.steps
        return min(max(int(steps + 0.5), 0), self.steps)   # a count held as a float

    def prediction(self, commands, estimate, steps=None):
        """The predicted state from the stored ``commands`` and the
        ``estimate``; ``steps`` (adaptive: the identified delay in ticks)
        takes the last that many commands (:meth:`taken`)."""
        if steps is not None:
            commands = commands[len(commands) - self.taken(steps):]
        return predict_state(estimate, commands, self.period, self.plant_params, self.friction,
                             constants=self._constants)

    def _store(self, context, discrete_state):
        buf = context.get_discrete_state(self._xd).get_value()
        discrete_state.get_mutable_vector(self._xd).SetFromVector(
            np.concatenate([buf[1:], self.command_port.Eval(context)]))
