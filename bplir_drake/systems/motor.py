"""Motor, gearbox and ESCON 50/5 driver (section 4.4).

Torque command -> current command ``i = tau / (Km N eta_g eta_m)`` (4.12),
torque saturation, dead-band (4.14): commands with ``|tau| < tau_min`` give
no current, driver current limit (15 A, cut to 5 A continuous by the i^2 t
interlock once 15 A has been held for 2.675 s), first-order current response
(time constant <= 10 ms).  The delivered torque ``Kt*i`` depends only on the
current state, so the motor has no direct feedthrough.

The i^2 t interlock: ``h' = i^2 - i_cont^2`` (clipped at zero) is integrated
at the driver period; the driver trips when ``h`` reaches
``(i_peak^2 - i_cont^2) t_peak`` (so a 15 A command is cut after 2.675 s) and
then limits the current to ``i_cont`` until ``h`` has returned to zero.
"""
from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem

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


class MotorDriver(LeafSystem):
    """Inputs ``torque_command`` (1) and ``state`` (4, plant state for power);
    outputs ``torque`` (delivered elbow torque), ``power`` (tau*q2d, W),
    ``current`` (A), ``tripped`` (1 while the driver limits to i_cont) and
    ``available`` (the torque the driver can deliver now, for anti-windup)."""

    def __init__(self, params: MotorParams):
        super().__init__()
        self.params = params
        self._kt = params.torque_per_amp
        self._budget = interlock_budget(params)
        self.DeclareVectorInputPort("torque_command", 1)
        self.DeclareVectorInputPort("state", 4)
        self._i = self.DeclareContinuousState(1)
        # discrete state: [i^2 t accumulator h, tripped flag]
        self._h = self.DeclareDiscreteState(2)
        self.DeclarePeriodicDiscreteUpdateEvent(params.driver_period, 0.0, self._update)
        xc = {self.xc_ticket()}
        self.DeclareVectorOutputPort("torque", 1, self._calc_torque, xc)
        self.DeclareVectorOutputPort(
            "power", 1, self._calc_power, {self.xc_ticket(), self.input_port_ticket(
                self.get_input_port(1).get_index())})
        self.DeclareVectorOutputPort("current", 1, self._calc_current, xc)
        self.DeclareVectorOutputPort("tripped", 1, self._calc_tripped,
                                     {self.xd_ticket()})
        self.DeclareVectorOutputPort("available", 1, self._calc_available,
                                     {self.xd_ticket()})

    def _tripped(self, context) -> bool:
        return context.get_discrete_state(self._h).GetAtIndex(1) > 0.5

    def DoCalcTimeDerivatives(self, context, derivatives):
        i = context.get_continuous_state_vector().GetAtIndex(0)
        tau_cmd = self.get_input_port(0).Eval(context)[0]
        target = current_command(tau_cmd, self.params, self._tripped(context))
        derivatives.get_mutable_vector().SetAtIndex(0, (target - i) / self.params.tau_current)

    def _update(self, context, discrete_state):
        i = context.get_continuous_state_vector().GetAtIndex(0)
        h, tripped = context.get_discrete_state(self._h).get_value()
        p = self.params
        h = max(0.0, h + p.driver_period * (i * i - p.i_cont ** 2))
        if h >= self._budget:
            tripped = 1.0
        elif h <= 0.0:
            tripped = 0.0
        discrete_state.get_mutable_vector(self._h).SetFromVector([h, tripped])

    def _calc_torque(self, context, out: BasicVector):
        out.SetAtIndex(0, self._kt * context.get_continuous_state_vector().GetAtIndex(0))

    def _calc_power(self, context, out: BasicVector):
        tau = self._kt * context.get_continuous_state_vector().GetAtIndex(0)
        out.SetAtIndex(0, tau * self.get_input_port(1).Eval(context)[3])

    def _calc_current(self, context, out: BasicVector):
        out.SetAtIndex(0, context.get_continuous_state_vector().GetAtIndex(0))

    def _calc_available(self, context, out: BasicVector):
        """Torque the driver can deliver now (current limit, saturation)."""
        i_lim = self.params.i_cont if self._tripped(context) else self.params.i_peak
        out.SetAtIndex(0, min(self.params.torque_limit, self._kt * i_lim))

    def _calc_tripped(self, context, out: BasicVector):
        out.SetAtIndex(0, 1.0 if self._tripped(context) else 0.0)


def max_torque(p: MotorParams) -> float:
    """Largest torque the motor can deliver (current limit and saturation)."""
    return min(p.torque_limit, p.torque_per_amp * p.i_peak)


__all__ = ["MotorDriver", "duty_cycle_to_current", "current_to_duty_cycle",
           "apply_deadband", "current_command", "interlock_budget", "max_torque"]
