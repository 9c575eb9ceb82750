"""Tracking a planned swing: a time-varying LQR around the plan.

The plan (:func:`bplir_drake.planning.solve.plan_swing`) is a
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
:mod:`bplir_drake.planning.solve`).  With ``indexing = "state"`` it
reads no clock: the plan is evaluated at the phase nearest to the estimate
(mostly in the joint angles; rates weigh (0.1 s)^2), searched forward
only.  The LQR's feedback then acts across the plan, not along it: timing
errors are no longer corrected, which costs captures (see the tests).

Near the line a terminal law takes over from the LQR: by default the apex
landing (:class:`Landing`), which aims the gripper at the capture band for
the moment link 1 stops, wherever a model or wind error makes it stop; the
reach (:class:`Reach`) is kept for comparison, off by default.

Outputs ``torque`` (the command) and ``reference`` (the plan's elbow angle).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .pysystem import PySystem
from ..params import PLAN_INDEXING
from .motor import torque_window_of
from .state import Q2, Q2D
from .schedule import declare_store, declare_tick_result
from .tracker_kernel import TRACKER_FIELDS, plan_tick, tracking_torque, window_constants
from .landing import Reach, Landing, ApexShot, terminal_rule


@dataclass(frozen=True)
class TrackerWeights:
    """LQR weights: state error (q1, q2, q1d, q2d), torque, final-state factor."""

    state: tuple = (100.0, 100.0, 10.0, 10.0)
    torque: float = 0.1
    final_factor: float = 10.0

    @classmethod
    def of(cls, plan) -> "TrackerWeights":
        """The weights of a ``plan`` parameter block (``lqr_state``,
        ``lqr_torque``, ``lqr_final``)."""
        return cls(state=tuple(float(v) for v in plan.lqr_state), torque=float(plan.lqr_torque),
                   final_factor=float(plan.lqr_final))


@dataclass(frozen=True)
class TrackingGains:
    """What the tracker evaluates of Drake's finite-horizon LQR result: the
    gain ``K(t)``, the nominal state ``x0(t)`` and torque ``u0(t)`` and the
    affine term ``k0(t)`` (Drake ``PiecewisePolynomial`` s)."""

    K: object
    x0: object
    u0: object
    k0: object


#: the error-controlled accuracy of the Riccati integration of
#: :func:`plan_gains`: the gains differ from those at 1e-4 by 2e-5 of their
#: largest value, at a twentieth of the time (0.25 s instead of 5.4 s)
RICCATI_ACCURACY = 1e-2


def plan_gains(model, times, states, torque,
               weights: TrackerWeights = TrackerWeights(),
               accuracy: float = RICCATI_ACCURACY) -> TrackingGains:
    """Drake's finite-horizon LQR of ``model`` (a diagram with one input, the
    elbow torque, and the state output) along the sampled plan, its Riccati
    equation integrated backwards by RK3 to ``accuracy``."""
    from pydrake.systems.analysis import SimulatorConfig
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
    opts.simulator_config = SimulatorConfig(integration_scheme="runge_kutta3",
                                            accuracy=float(accuracy), max_step_size=0.1)
    result = FiniteHorizonLinearQuadraticRegulator(model, model.CreateDefaultContext(),
                                                   float(times[0]), float(times[-1]), Q, R,
                                                   opts)
    return TrackingGains(result.K, result.x0, result.u0, result.k0)


class PlanTracker(PySystem):
    """Input ``state`` (estimated relative state).  Outputs ``torque`` and
    ``reference`` (q2 of the plan), both held between ticks of ``period``.

    ``indexing``: ``"time"`` evaluates the plan at the time since the start;
    ``"state"`` at a phase ``tau`` found from the estimate alone: every tick
    ``tau`` moves to the plan point nearest to ``x_hat`` (squared errors
    weighted by ``phase_weights``) within ``[tau, tau + search]`` s, on a
    grid of a quarter period, so it never goes back and never reads the
    clock.  ``lead`` (s): with ``"time"`` the plan is read this much later
    (the state input is then the state predicted this far ahead, over the
    actuation delay).  ``reach``: the terminal law (:class:`Landing` or
    :class:`Reach`), which takes over near the line in the plan's last
    forward swing of link 1 (after ``t_final``) and latches (discrete
    state: phase, tick count, reach flag).

    ``probe``: torques (N m) added to the commands of ticks 0, 1, ... (the
    delay probe of :mod:`bplir_drake.systems.delay_id`).  With
    ``adaptive_lead`` the lead is ``delay_steps`` ticks, read from that
    input (an identified delay) instead of ``lead``.  ``motor`` (the
    nominal motor, optional): every command is clipped to the torque the
    motor can deliver at the state input's elbow rate
    (:func:`~bplir_drake.systems.motor.torque_window`: the voltage envelope
    and the peak current), the torque it asks for beyond that would not
    come (the planner holds the plan to the envelope; the feedback and the
    terminal law are not planned)."""

    def __init__(self, gains, torque_limit: float, period: float,
                 indexing: str = "time", phase_weights=(1.0, 1.0, 0.01, 0.01),
                 search: float = 0.05, reach: Landing | Reach | ApexShot | None = None,
                 lead: float = 0.0, probe=(), adaptive_lead: bool = False,
                 motor=None):
        super().__init__()
        self.motor = motor
        self._window = (torque_window_of(motor, torque_limit=float(torque_limit))
                        if motor is not None else None)
        self._wc = window_constants(motor, torque_limit)
        # the compiled tick's terminal law (tracker_kernel.plan_tick)
        self._rule = terminal_rule(reach)
        self._shot_c = reach.constants if isinstance(reach, ApexShot) else np.zeros(1)
        self._rows = {}   # the plan's rows at the ticks, by lead
        self.reach, self.lead = reach, float(lead)
        self.probe = tuple(float(u) for u in probe)
        self._probe = np.array(self.probe, dtype=float)
        if indexing not in PLAN_INDEXING:
            raise ValueError(f"indexing = {indexing!r}; allowed: " + ", ".join(PLAN_INDEXING))
        self.K, self.x0, self.u0, self.k0 = gains.K, gains.x0, gains.u0, gains.k0
        self.t_end = self.x0.end_time()
        self._plan_values = {}   # plan_at's
        # the terminal law may take over in the plan's last forward swing of link 1
        # (a climbing plan swings link 1 back first), and in its second half
        ts = np.linspace(0.0, self.t_end, 401)
        back = ts[self.x0.vector_values(ts)[2] < -0.05]   # link 1 swings back (rad/s)
        self.t_final = max(0.5 * self.t_end, float(back[-1]) if back.size else 0.0)
        self.torque_limit = float(torque_limit)
        self.indexing = indexing
        self._W = np.asarray(phase_weights, dtype=float)
        n = max(2, int(round(search / (period / 4))) + 1)
        self._steps = np.linspace(0.0, search, n)
        self.period = period
        self.state_port = self.DeclareVectorInputPort("state", 4)
        self.steps_port = (self.DeclareVectorInputPort("delay_steps", 1) if adaptive_lead
                           else None)
        self._xd = self.DeclareDiscreteState(len(TRACKER_FIELDS))
        self._tick = declare_tick_result(self, self._tick_law,
                                         {self.xd_ticket(), self.all_input_ports_ticket()})
        declare_store(self, period, self._store)
        dep = {self._tick.ticket()}
        self.DeclareVectorOutputPort("torque", 1, lambda c, o: o.SetAtIndex(
            0, self._tick.Eval(c)[0]), dep)
        self.DeclareVectorOutputPort("reference", 1, lambda c, o: o.SetAtIndex(
            0, self._tick.Eval(c)[1]), dep)

    def reaching(self, t: float, x, reached: float) -> bool:
        """Whether the terminal law runs (it latches)."""
        r = self.reach
        if r is None:
            return False
        return bool(reached > 0.5 or t >= self.t_end
                    or (t > self.t_final and r.takes_over(x)))

    def law(self, t: float, x, reach: bool = False) -> tuple[float, float]:
        """(torque, planned q2) at time ``t`` (held at the plan's end after it)."""
        t = min(max(t, 0.0), self.t_end)
        x0, u0, K, k0 = self.plan_at(t)
        if not reach:   # compiled: tracker_kernel.tracking_torque
            return (tracking_torque(np.asarray(x, dtype=float), x0, u0, K[0], k0, self._wc),
                    float(x0[Q2]))   # the planned q2
        lo, hi = self.window(x)
        if isinstance(self.reach, ApexShot):
            u = self.reach.torque(np.asarray(x, dtype=float), window=(lo, hi))
        else:
            u = self.reach.torque(np.asarray(x, dtype=float))
        return float(min(max(u, lo), hi)), float(x0[1])

    def plan_at(self, t: float):
        """(x0, u0, K, k0): the plan and its gains at ``t``, kept for the
        times the tracker has asked for (with ``"time"`` indexing the same
        few hundred ticks every swing of the plan)."""
        got = self._plan_values.get(t)
        if got is None:
            got = (self.x0.value(t).ravel(), self.u0.value(t)[0, 0], self.K.value(t),
                   self.k0.value(t)[0, 0])
            if len(self._plan_values) < 4096:
                self._plan_values[t] = got
        return got

    def lead_at(self, steps=None) -> float:
        """The lead (s): ``lead``, or with an adaptive lead ``steps`` (the
        identified delay in ticks) rounded to whole ticks."""
        return self.lead if steps is None else math.floor(steps + 0.5) * self.period

    def plan_rows(self, lead: float):
        """(x0, u0, K, k0) of :meth:`plan_at` as arrays, row ``i`` at the
        time ``i period + lead`` (within the plan), the last at its end:
        what a time-indexed tick with that lead reads (kept for 16 leads)."""
        rows = self._rows.get(lead)
        if rows is None:
            got, i = [], 0
            while True:
                tau = float(i) * self.period + lead
                got.append(self.plan_at(min(max(tau, 0.0), self.t_end)))
                if tau >= self.t_end:
                    break
                i += 1
            x0, u0, K, k0 = zip(*got)
            rows = (np.array(x0), np.array(u0, dtype=float), np.array([row for (row,) in K]),
                    np.array(k0, dtype=float))
            if len(self._rows) < 16:
                self._rows[lead] = rows
        return rows

    def compiled_tick(self, steps=None) -> tuple:
        """What :func:`~bplir_drake.systems.tracker_kernel.plan_tick` reads
        beside the state, the tick and the period: (the lead at ``steps``,
        the plan's end, the time from which its terminal law may take over,
        :meth:`plan_rows` at that lead, the terminal law as numbers, the apex
        shot's nominal model, the motor's torque window, the delay probe)."""
        lead = self.lead_at(steps)
        return (float(lead), self.t_end, self.t_final, *self.plan_rows(lead), self._rule,
                self._shot_c, self._wc, self._probe)

    def window(self, x) -> tuple[float, float]:
        """(lowest, highest) torque the tracker commands at the state ``x``."""
        if self.motor is None:
            return -self.torque_limit, self.torque_limit
        return self._window(float(x[Q2D]))

    def phase(self, tau: float, x) -> float:
        """The plan time nearest to ``x`` in ``[tau, tau + search]``."""
        cand = np.minimum(tau + self._steps, self.t_end)
        X = self.x0.vector_values(cand)  # 4 x n
        d = self._W @ (X - np.asarray(x).reshape(4, 1)) ** 2
        return float(cand[int(np.argmin(d))])

    def _tick_law(self, context):
        return self.tick(self.state_port.Eval(context),
                         context.get_discrete_state(self._xd).get_value(),
                         self.steps_port.Eval(context)[0] if self.steps_port is not None
                         else None)

    def tick(self, x, xd, steps=None):
        """(torque, planned q2, phase tau, tick count, reach) of the tick
        from the state input ``x``, the stored ``xd`` (phase, tick count,
        reach) and, with an adaptive lead, ``steps`` (the identified delay);
        with ``"time"`` indexing the phase is the tick's time ``k T``."""
        tau_prev, k, reached = xd.tolist() if isinstance(xd, np.ndarray) else xd
        if self.indexing == "time":   # compiled, but for a terminal law other than the shot
            lead, *constants = self.compiled_tick(steps)
            status, u, reference, tau = plan_tick(
                np.asarray(x, dtype=float), float(k), float(reached), lead, self.period,
                *constants)
            if status < 2:
                return (u, reference, tau, k + 1, float(status))
        lead = self.lead_at(steps)
        tau = k * self.period + lead if self.indexing == "time" else self.phase(tau_prev, x)
        reach = self.reaching(tau, x, reached)
        u, reference = self.law(tau, x, reach)
        i = int(k + 0.5)   # counts held as floats
        if i < len(self.probe):
            lo, hi = self.window(x)
            u = float(min(max(u + self.probe[i], lo), hi))
        return (u, reference, tau, k + 1, float(reach))

    def _store(self, context, discrete_state):
        discrete_state.get_mutable_vector(self._xd).SetFromVector(self._tick.Eval(context)[2:])
