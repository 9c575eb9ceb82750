"""Tracking a planned swing: a time-varying LQR around the plan.

The plan (:func:`bplir_drake.analysis.swing_plan.plan_swing`) is a
full-state trajectory of the *nominal* model.  Drake's
``FiniteHorizonLinearQuadraticRegulator`` linearises the nominal plant (with
its friction model) along it and integrates the Riccati equation backwards;
this system applies ``tau = u0(t) - K(t) (x_hat - x0(t)) - k0(t)`` to the
estimated state every controller period (zero-order hold), clipped to the
torque limit.

Unlike the path generator this controller is indexed by **time** since the
start of the swing: it is the way to climb a steep line, where the planned
motion swings link 1 back before going forward and so is not a path
``q2 = phi(q1)`` (see :mod:`bplir_drake.analysis.swing_plan`).

Outputs ``torque`` (the command) and ``reference`` (the plan's elbow angle).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import LeafSystem


@dataclass(frozen=True)
class TrackerWeights:
    """LQR weights: state error (q1, q2, q1d, q2d), torque, final-state factor."""

    state: tuple = (100.0, 100.0, 10.0, 10.0)
    torque: float = 0.1
    final_factor: float = 10.0


def plan_gains(model, times, states, torque, weights: TrackerWeights = TrackerWeights()):
    """Drake's finite-horizon LQR of ``model`` (a diagram with one input, the
    elbow torque, and the state output) along the sampled plan."""
    from pydrake.systems.controllers import (FiniteHorizonLinearQuadraticRegulator,
                                             FiniteHorizonLinearQuadraticRegulatorOptions)
    from pydrake.trajectories import PiecewisePolynomial

    Q = np.diag(weights.state)
    R = np.array([[weights.torque]])
    opts = FiniteHorizonLinearQuadraticRegulatorOptions()
    opts.x0 = PiecewisePolynomial.FirstOrderHold(times, np.asarray(states).T)
    opts.u0 = PiecewisePolynomial.FirstOrderHold(times, np.asarray(torque).reshape(1, -1))
    opts.Qf = Q * weights.final_factor
    opts.input_port_index = model.get_input_port(0).get_index()
    return FiniteHorizonLinearQuadraticRegulator(model, model.CreateDefaultContext(),
                                                 float(times[0]), float(times[-1]), Q, R, opts)


class PlanTracker(LeafSystem):
    """Input ``state`` (estimated relative state).  Outputs ``torque`` and
    ``reference`` (q2 of the plan), both held between ticks of ``period``."""

    def __init__(self, gains, torque_limit: float, period: float, offset: float = 0.0):
        super().__init__()
        self.K, self.x0, self.u0, self.k0 = gains.K, gains.x0, gains.u0, gains.k0
        self.t_end = self.x0.end_time()
        self.torque_limit = float(torque_limit)
        self.DeclareVectorInputPort("state", 4)
        self._xd = self.DeclareDiscreteState(2)  # [torque, reference]
        self.DeclarePeriodicDiscreteUpdateEvent(period, offset, self._update)
        self.DeclareVectorOutputPort("torque", 1, lambda c, o: o.SetAtIndex(
            0, c.get_discrete_state(self._xd).GetAtIndex(0)), {self.xd_ticket()})
        self.DeclareVectorOutputPort("reference", 1, lambda c, o: o.SetAtIndex(
            0, c.get_discrete_state(self._xd).GetAtIndex(1)), {self.xd_ticket()})

    def law(self, t: float, x) -> tuple[float, float]:
        """(torque, planned q2) at time ``t`` (held at the plan's end after it)."""
        t = min(max(t, 0.0), self.t_end)
        x0 = self.x0.value(t).ravel()
        u = self.u0.value(t)[0, 0] - (self.K.value(t) @ (np.asarray(x) - x0))[0] \
            - self.k0.value(t)[0, 0]
        return float(np.clip(u, -self.torque_limit, self.torque_limit)), float(x0[1])

    def _update(self, context, discrete_state):
        x = self.get_input_port(0).Eval(context)
        discrete_state.get_mutable_vector(self._xd).SetFromVector(
            self.law(context.get_time(), x))
