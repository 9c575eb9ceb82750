"""Motor, gearbox and ESCON 50/5 driver (section 4.4).

Torque command -> current command ``i = tau / (Km N eta_g eta_m)`` (4.12),
torque saturation, dead-band (4.14): commands with ``|tau| < tau_min`` give
no current, driver current limit (15 A, cut to 5 A continuous by the i^2 t
interlock once 15 A has been held for 2.675 s), first-order current response
(time constant <= 10 ms).  The delivered torque ``Kt*i`` depends only on the
current state, so the motor has no direct feedthrough.  The current loop is a
C++ ``LinearSystem`` driven by the target current, which changes only when the
command or the trip state does (:class:`MotorDriver`).

The i^2 t interlock: ``h' = i^2 - i_cont^2`` (clipped at zero) is integrated
at the driver period; the driver trips when ``h`` reaches
``(i_peak^2 - i_cont^2) t_peak`` (so a 15 A command is cut after 2.675 s) and
then limits the current to ``i_cont`` until ``h`` has returned to zero.
"""
from __future__ import annotations

import numpy as np
from pydrake.systems.framework import Diagram, LeafSystem

from ..params import MotorParams


def duty_cycle_to_current(duty_percent):
    """(4.13): PWM duty cycle in percent -> ESCON current reference in A."""
    d = np.asarray(duty_percent, dtype=float)
    return np.where(d >= 90.0, 15.0, np.where(d <= 10.0, 0.0, 15.0 / 80.0 * d - 15.0 / 8.0))


def current_to_duty_cycle(current):
    """Inverse of (4.13) on its linear part (0..15 A -> 10..90 %)."""
    i = np.clip(np.asarray(current, dtype=float), 0.0, 15.0)
    return (i + 15.0 / 8.0) * 80.0 / 15.0


def apply_deadband(tau, deadband: float):
    """(4.14): torques with magnitude below the dead-band produce nothing."""
    tau = np.asarray(tau, dtype=float)
    return np.where(np.abs(tau) < deadband, 0.0, tau)


def current_command(tau_cmd: float, p: MotorParams, tripped: bool) -> float:
    """Current the driver regulates to for a torque command."""
    # plain min/max: this runs at every integrator stage (np.clip on a scalar is slow)
    tau = min(max(float(tau_cmd), -p.torque_limit), p.torque_limit)
    if abs(tau) < p.deadband:
        return 0.0
    i_lim = p.i_cont if tripped else p.i_peak
    return min(max(tau / p.torque_per_amp, -i_lim), i_lim)


def interlock_budget(p: MotorParams) -> float:
    """i^2 t budget (A^2 s) above the continuous current before the driver trips."""
    return (p.i_peak ** 2 - p.i_cont ** 2) * p.t_peak


def i2t_trace(h0: float, currents, p: MotorParams, tripped: bool = False):
    """The driver's ``(h, tripped)`` after each ``driver_period`` of the
    current sequence ``currents`` (A), from ``(h0, tripped)``: the update of
    :class:`DriverLogic` run offline (a plan's currents, a rest)."""
    budget = interlock_budget(p)
    h, out_h, out_t = float(h0), [], []
    for i in np.asarray(currents, dtype=float):
        h = max(0.0, h + p.driver_period * (i * i - p.i_cont ** 2))
        tripped = True if h >= budget else (False if h <= 0.0 else tripped)
        out_h.append(h)
        out_t.append(tripped)
    return np.array(out_h), np.array(out_t, dtype=bool)


def i2t_after_rest(h: float, duration: float, p: MotorParams) -> float:
    """``h`` after ``duration`` s without current (it falls at ``i_cont^2``)."""
    return max(0.0, h - p.i_cont ** 2 * duration)


def rest_for(h: float, tripped: bool, currents, p: MotorParams, margin: float) -> float:
    """The shortest rest (s) after which the current sequence ``currents``
    (a planned swing, one value per driver period) keeps ``h`` below
    ``(1 - margin)`` of the budget; a tripped driver first rests until it
    resets (``h`` back to zero)."""
    limit = (1.0 - margin) * interlock_budget(p)
    rate = p.i_cont ** 2

    def peak(h0):
        return float(np.max(i2t_trace(h0, currents, p)[0], initial=h0))

    if tripped:
        return h / rate
    if peak(h) <= limit:
        return 0.0
    lo, hi = 0.0, h / rate  # a full reset is enough unless the swing alone exceeds the limit
    if peak(0.0) > limit:
        return hi
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if peak(i2t_after_rest(h, mid, p)) <= limit else (mid, hi)
    return hi


class DriverLogic(LeafSystem):
    """The driver's discrete logic (one Python evaluation a tick at most):
    the current it regulates to for the torque command
    (:func:`current_command`: saturation, dead-band, current limit) and the
    i^2 t interlock, updated every ``driver_period`` from the measured current.

    Inputs ``torque_command`` (N m) and ``current`` (A, measured); discrete
    state ``(h, tripped)``; outputs ``target_current`` (depends on the command
    and the state only), ``tripped`` and ``available`` (the torque the driver
    can deliver now, for anti-windup)."""

    def __init__(self, params: MotorParams):
        super().__init__()
        self.params = params
        self._budget = interlock_budget(params)
        self.command_port = cmd = self.DeclareVectorInputPort("torque_command", 1)
        self.current_port = self.DeclareVectorInputPort("current", 1)
        self._h = self.DeclareDiscreteState(2)
        self.DeclarePeriodicDiscreteUpdateEvent(params.driver_period, 0.0, self._update)
        xd = {self.xd_ticket()}
        self.DeclareVectorOutputPort("target_current", 1, self._calc_target,
                                     {self.xd_ticket(), cmd.ticket()})
        self.DeclareVectorOutputPort("tripped", 1, self._calc_tripped, xd)
        self.DeclareVectorOutputPort("available", 1, self._calc_available, xd)

    def _tripped(self, context) -> bool:
        return context.get_discrete_state(self._h).GetAtIndex(1) > 0.5

    def interlock_state(self, context) -> tuple[float, bool]:
        """``(h, tripped)``: the i^2 t integral (A^2 s) and the trip flag."""
        h, tripped = context.get_discrete_state(self._h).get_value()
        return float(h), bool(tripped > 0.5)

    def set_interlock_state(self, context, h: float, tripped: bool) -> None:
        """Start from ``(h, tripped)`` (a driver carried over from earlier work)."""
        context.SetDiscreteState(self._h, [float(h), 1.0 if tripped else 0.0])

    def _update(self, context, discrete_state):
        i = self.current_port.Eval(context)[0]
        h, tripped = context.get_discrete_state(self._h).get_value()
        p = self.params
        h = max(0.0, h + p.driver_period * (i * i - p.i_cont ** 2))
        if h >= self._budget:
            tripped = 1.0
        elif h <= 0.0:
            tripped = 0.0
        discrete_state.get_mutable_vector(self._h).SetFromVector([h, tripped])

    def _calc_target(self, context, out):
        tau = self.command_port.Eval(context)[0]
        out.SetAtIndex(0, current_command(tau, self.params, self._tripped(context)))

    def _calc_tripped(self, context, out):
        out.SetAtIndex(0, 1.0 if self._tripped(context) else 0.0)

    def _calc_available(self, context, out):
        p = self.params
        i_lim = p.i_cont if self._tripped(context) else p.i_peak
        out.SetAtIndex(0, min(p.torque_limit, p.torque_per_amp * i_lim))


def _motor_power(p: MotorParams):
    """Electrical-to-mechanical power meter (C++ symbolic): input ``(i, q1,
    q2, q1d, q2d)``, output ``tau q2d`` (W), state the motor's work (J)."""
    from pydrake.symbolic import MakeVectorVariable, Variable
    from pydrake.systems.primitives import SymbolicVectorSystem

    u = MakeVectorVariable(5, "u")
    power = p.torque_per_amp * u[0] * u[4]
    return SymbolicVectorSystem(state=[Variable("work")], input=u, dynamics=[power],
                                output=[power])


class MotorDriver(Diagram):
    """Motor and driver as a diagram in which no Python runs while the
    integrator steps:

    * ``driver`` (:class:`DriverLogic`, discrete): the target current of the
      command and the i^2 t interlock;
    * ``current_loop`` (C++ ``LinearSystem``): the current follows the target
      with the time constant ``tau_current``; state ``i / i_peak``, outputs
      ``(Kt i, i)``;
    * ``power_meter`` (C++ symbolic): ``tau q2d`` and the motor's work.

    Inputs ``torque_command`` (1) and ``state`` (4, plant state for the
    power); outputs ``torque`` (delivered elbow torque), ``power`` (tau*q2d,
    W), ``current`` (A), ``tripped`` (1 while the driver limits to i_cont)
    and ``available``.  The delivered torque depends only on the current
    state: no direct feedthrough from the command."""

    def __init__(self, params: MotorParams):
        from pydrake.systems.framework import DiagramBuilder
        from pydrake.systems.primitives import Demultiplexer, LinearSystem, Multiplexer

        super().__init__()
        self.params = params
        tau, kt = params.tau_current, params.torque_per_amp
        b = DiagramBuilder()
        logic = b.AddNamedSystem("driver", DriverLogic(params))
        # state: the current in units of the peak current (the integrator's
        # error control then weighs it like the joint angles)
        ip = params.i_peak
        loop = b.AddNamedSystem("current_loop", LinearSystem(
            [[-1.0 / tau]], [[1.0 / (tau * ip)]], [[kt * ip], [ip]], [[0.0], [0.0]]))
        meter = b.AddNamedSystem("power_meter", _motor_power(params))
        split = b.AddSystem(Demultiplexer(2))
        mux = b.AddSystem(Multiplexer([1, 4]))
        b.ExportInput(logic.GetInputPort("torque_command"), "torque_command")
        b.ExportInput(mux.get_input_port(1), "state")
        b.Connect(logic.GetOutputPort("target_current"), loop.get_input_port(0))
        b.Connect(loop.get_output_port(0), split.get_input_port(0))
        b.Connect(split.get_output_port(1), logic.GetInputPort("current"))
        b.Connect(split.get_output_port(1), mux.get_input_port(0))
        b.Connect(mux.get_output_port(0), meter.get_input_port(0))
        b.ExportOutput(split.get_output_port(0), "torque")
        b.ExportOutput(meter.get_output_port(0), "power")
        b.ExportOutput(split.get_output_port(1), "current")
        b.ExportOutput(logic.GetOutputPort("tripped"), "tripped")
        b.ExportOutput(logic.GetOutputPort("available"), "available")
        b.BuildInto(self)


def max_torque(p: MotorParams) -> float:
    """Largest torque the motor can deliver (current limit and saturation)."""
    return min(p.torque_limit, p.torque_per_amp * p.i_peak)


__all__ = ["MotorDriver", "duty_cycle_to_current", "current_to_duty_cycle",
           "DriverLogic", "apply_deadband", "current_command", "interlock_budget", "max_torque",
           "i2t_trace", "i2t_after_rest", "rest_for"]
