"""Tracking a planned swing: a time-varying LQR around the plan.

The plan (:func:`bplir_drake.analysis.swing.plan.plan_swing`) is a
full-state trajectory of the *nominal* model.  Drake's
``FiniteHorizonLinearQuadraticRegulator`` linearises the nominal plant (with
its friction model) along it and integrates the Riccati equation backwards;
this system applies ``tau = u0(t) - K(t) (x_hat - x0(t)) - k0(t)`` to the
estimated state every controller period (zero-order hold, on the tick
schedule of :mod:`bplir_drake.systems.schedule`), clipped to the torque
limit.

By default this controller is indexed by **time** since the start of the
swing: it is the way to climb a steep line, where the planned motion swings
link 1 back before going forward and so is not a path ``q2 = phi(q1)`` (see
:mod:`bplir_drake.analysis.swing.plan`).  With ``indexing = "state"`` it
reads no clock: the plan is evaluated at the phase nearest to the estimate
(mostly in the joint angles; rates weigh (0.1 s)^2), searched forward
only.  The LQR's feedback then acts across the plan, not along it: timing
errors are no longer corrected, which costs captures (see the tests).

Outputs ``torque`` (the command) and ``reference`` (the plan's elbow angle).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import LeafSystem

from ..params import PLAN_INDEXING
from .schedule import declare_store, declare_tick_result


@dataclass(frozen=True)
class TrackerWeights:
    """LQR weights: state error (q1, q2, q1d, q2d), torque, final-state factor."""

    state: tuple = (100.0, 100.0, 10.0, 10.0)
    torque: float = 0.1
    final_factor: float = 10.0


@dataclass(frozen=True)
class TrackingGains:
    """What the tracker evaluates of Drake's finite-horizon LQR result: the
    gain ``K(t)``, the nominal state ``x0(t)`` and torque ``u0(t)`` and the
    affine term ``k0(t)`` (Drake ``PiecewisePolynomial`` s)."""

    K: object
    x0: object
    u0: object
    k0: object


def plan_gains(model, times, states, torque,
               weights: TrackerWeights = TrackerWeights()) -> TrackingGains:
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
    result = FiniteHorizonLinearQuadraticRegulator(model, model.CreateDefaultContext(),
                                                   float(times[0]), float(times[-1]), Q, R,
                                                   opts)
    return TrackingGains(result.K, result.x0, result.u0, result.k0)


class PlanTracker(LeafSystem):
    """Input ``state`` (estimated relative state).  Outputs ``torque`` and
    ``reference`` (q2 of the plan), both held between ticks of ``period``.

    ``indexing``: ``"time"`` evaluates the plan at the time since the start;
    ``"state"`` at a phase ``tau`` found from the estimate alone: every tick
    ``tau`` moves to the plan point nearest to ``x_hat`` (squared errors
    weighted by ``phase_weights``) within ``[tau, tau + search]`` s, on a
    grid of a quarter period, so it never goes back and never reads the
    clock."""

    def __init__(self, gains, torque_limit: float, period: float,
                 indexing: str = "time", phase_weights=(1.0, 1.0, 0.01, 0.01),
                 search: float = 0.05):
        super().__init__()
        if indexing not in PLAN_INDEXING:
            raise ValueError(f"indexing = {indexing!r}; allowed: " + ", ".join(PLAN_INDEXING))
        self.K, self.x0, self.u0, self.k0 = gains.K, gains.x0, gains.u0, gains.k0
        self.t_end = self.x0.end_time()
        self.torque_limit = float(torque_limit)
        self.indexing = indexing
        self._W = np.asarray(phase_weights, dtype=float)
        n = max(2, int(round(search / (period / 4))) + 1)
        self._steps = np.linspace(0.0, search, n)
        self.period = period
        self.DeclareVectorInputPort("state", 4)
        self._xd = self.DeclareDiscreteState(2)  # [phase tau of the last tick, tick count]
        self._tick = declare_tick_result(self, self._tick_law,
                                         {self.xd_ticket(), self.all_input_ports_ticket()})
        declare_store(self, period, self._store)
        dep = {self._tick.ticket()}
        self.DeclareVectorOutputPort("torque", 1, lambda c, o: o.SetAtIndex(
            0, self._tick.Eval(c)[0]), dep)
        self.DeclareVectorOutputPort("reference", 1, lambda c, o: o.SetAtIndex(
            0, self._tick.Eval(c)[1]), dep)

    def law(self, t: float, x) -> tuple[float, float]:
        """(torque, planned q2) at time ``t`` (held at the plan's end after it)."""
        t = min(max(t, 0.0), self.t_end)
        x0 = self.x0.value(t).ravel()
        u = self.u0.value(t)[0, 0] - (self.K.value(t) @ (np.asarray(x) - x0))[0] \
            - self.k0.value(t)[0, 0]
        return float(np.clip(u, -self.torque_limit, self.torque_limit)), float(x0[1])

    def phase(self, tau: float, x) -> float:
        """The plan time nearest to ``x`` in ``[tau, tau + search]``."""
        cand = np.minimum(tau + self._steps, self.t_end)
        X = self.x0.vector_values(cand)  # 4 x n
        d = self._W @ (X - np.asarray(x).reshape(4, 1)) ** 2
        return float(cand[int(np.argmin(d))])

    def _tick_law(self, context):
        """(torque, planned q2, phase tau, tick count) of this tick; with
        ``"time"`` indexing the phase is the tick's time ``k T``."""
        x = self.get_input_port(0).Eval(context)
        tau_prev, k = context.get_discrete_state(self._xd).get_value()
        tau = k * self.period if self.indexing == "time" else self.phase(tau_prev, x)
        return (*self.law(tau, x), tau, k + 1)

    def _store(self, context, discrete_state):
        discrete_state.get_mutable_vector(self._xd).SetFromVector(self._tick.Eval(context)[2:])
