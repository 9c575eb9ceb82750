"""Motor, gearbox and ESCON 50/5 driver (section 4.4).

Torque command -> current command ``i = tau / (Km N eta_g eta_m)`` (4.12),
torque saturation, dead-band (4.14): commands with ``|tau| < tau_min`` give
no current, driver current limit (15 A, cut to 5 A continuous by the i^2 t
interlock once 15 A has been held for 2.675 s), first-order current response
(time constant <= 10 ms).  The delivered torque ``Kt*i`` depends only on the
current state, so the motor has no direct feedthrough.  The current loop is a
C++ symbolic system driven by the target current, which changes only when the
command or the trip state does (:class:`MotorDriver`).

The voltage envelope (Table 4.2): the driver can put at most
``V_max = voltage_fraction * supply_voltage`` across the winding, whose
resistance is ``R`` and whose back-EMF is ``Km N q2'`` (the back-EMF constant
equals the torque constant in SI units), so the current is confined to
``[(-V_max - Km N q2')/R, (V_max - Km N q2')/R]`` (:func:`current_window`).
The current loop follows its target with ``tau_current``; the current that
flows is that state clipped to the window, so the winding voltage
``R i + Km N q2'`` never leaves ``[-V_max, V_max]``: motoring runs out of
voltage as the elbow speeds up, braking does not (the back-EMF helps it).  The
winding inductance (an electrical time constant well under the 5 ms loop) is
neglected.  Braking power (``V i < 0``) flows back into the supply
(the ESCON is a four-quadrant driver; a battery takes it): it is logged as
negative electrical power and summed as the regenerated energy.

The i^2 t interlock: ``h' = i^2 - i_cont^2`` (clipped at zero) is integrated
at the driver period; the driver trips when ``h`` reaches
``(i_peak^2 - i_cont^2) t_peak`` (so a 15 A command is cut after 2.675 s) and
then limits the current to ``i_cont`` until ``h`` has returned to zero.
"""
from __future__ import annotations

import numpy as np
from pydrake.systems.framework import Diagram

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


def back_emf(q2d, p: MotorParams):
    """The winding's back-EMF (V) at the elbow rate ``q2d`` (rad/s)."""
    return p.back_emf_constant * p.gear_ratio * q2d


def current_window(q2d, p: MotorParams):
    """(lowest, highest) current (A) the driver's voltage can drive at the
    elbow rate ``q2d``; ``(-inf, inf)`` without the envelope."""
    if not p.envelope:
        return -np.inf, np.inf
    e = back_emf(q2d, p)
    return (-p.max_voltage - e) / p.resistance, (p.max_voltage - e) / p.resistance


def torque_window(q2d: float, p: MotorParams, i_limit: float | None = None,
                  torque_limit: float | None = None) -> tuple[float, float]:
    """(lowest, highest) elbow torque (N m) the motor can deliver at the
    elbow rate ``q2d``: the voltage envelope, the current limit ``i_limit``
    (default ``i_peak``) and the torque saturation (default ``torque_limit``)."""
    return torque_window_of(p, i_limit, torque_limit)(q2d)


def torque_window_of(p: MotorParams, i_limit: float | None = None,
                     torque_limit: float | None = None):
    """:func:`torque_window` of ``p`` as a function of the elbow rate alone,
    its constants worked out once (a controller asks every tick): the
    current window of :func:`current_window` in the same arithmetic."""
    i_lim = p.i_peak if i_limit is None else i_limit
    t_lim = p.torque_limit if torque_limit is None else torque_limit
    kt, emf_per_rate = p.torque_per_amp, p.back_emf_constant * p.gear_ratio
    v, r, envelope = p.max_voltage, p.resistance, p.envelope

    def window(q2d: float) -> tuple[float, float]:
        if envelope:
            e = emf_per_rate * q2d
            lo, hi = (-v - e) / r, (v - e) / r
        else:
            lo, hi = -np.inf, np.inf
        lo_t = max(-t_lim, kt * max(lo, -i_lim))
        return lo_t, max(lo_t, min(t_lim, kt * min(hi, i_lim)))

    return window


def no_load_speed(p: MotorParams, voltage: float | None = None) -> float:
    """The elbow rate (rad/s) at which the back-EMF equals ``voltage``
    (default the driver's largest output voltage)."""
    v = p.max_voltage if voltage is None else voltage
    return v / (p.back_emf_constant * p.gear_ratio)


def stall_torque(p: MotorParams, voltage: float | None = None) -> float:
    """The motor shaft's torque (N m) at rest with ``voltage`` across the
    winding and no current limit: ``Km V / R`` (before the gearbox)."""
    v = p.max_voltage if voltage is None else voltage
    return p.km * v / p.resistance


def envelope_curve(p: MotorParams, speeds) -> np.ndarray:
    """(n, 2): the lowest and highest deliverable elbow torque at each
    elbow rate in ``speeds`` (current limit ``i_peak``, torque saturation)."""
    return np.array([torque_window(float(w), p) for w in np.asarray(speeds, dtype=float)])


def interlock_budget(p: MotorParams) -> float:
    """i^2 t budget (A^2 s) above the continuous current before the driver trips."""
    return (p.i_peak ** 2 - p.i_cont ** 2) * p.t_peak


def i2t_trace(h0: float, currents, p: MotorParams, tripped: bool = False):
    """The driver's ``(h, tripped)`` after each ``driver_period`` of the
    current sequence ``currents`` (A), from ``(h0, tripped)``: the update of
    the motor's driver run offline (a plan's currents, a rest)."""
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


def _target_current(tau_cmd, tripped, p: MotorParams):
    """:func:`current_command` of a symbolic command and trip state."""
    from pydrake.symbolic import abs as sabs, if_then_else, max as smax, min as smin

    tau = smin(smax(tau_cmd, -p.torque_limit), p.torque_limit)
    i_lim = if_then_else(tripped > 0.5, p.i_cont, p.i_peak)
    return if_then_else(sabs(tau) < p.deadband, 0.0,
                        smin(smax(tau / p.torque_per_amp, -i_lim), i_lim))


def _electrics(p: MotorParams):
    """The current loop, the meters and the i^2 t interlock's next state
    (C++ symbolic).

    Input ``(torque command, h, tripped, q1, q2, q1d, q2d)`` (``h``,
    ``tripped``: the interlock's state, held between its updates); state
    ``(i_loop / i_peak, mechanical work, electrical energy, copper loss,
    regenerated energy)``; output :data:`ELECTRIC_OUTPUTS`, then the
    interlock's next ``(h, tripped)``.  The loop follows the target current of the
    command (:func:`current_command`: saturation, dead-band, current limit);
    the current is the loop's state clipped to the voltage window at the
    present ``q2d`` (:func:`current_window`).  The interlock: ``h <- max(0, h
    + driver_period (i^2 - i_cont^2))``, tripped once ``h`` reaches
    :func:`interlock_budget` until it is back at zero (:func:`i2t_trace`
    runs the same update offline)."""
    from pydrake.symbolic import (MakeVectorVariable, Variable, if_then_else, max as smax,
                                  min as smin)
    from pydrake.systems.primitives import SymbolicVectorSystem

    u = MakeVectorVariable(7, "u")
    x = [Variable(n) for n in ("i_loop", "work", "electrical", "copper", "regenerated")]
    ip, kt = p.i_peak, p.torque_per_amp
    h, tripped, q2d = u[1], u[2], u[6]
    emf = back_emf(q2d, p)
    i = ip * x[0]
    if p.envelope:   # the same window the controllers and the planner use, symbolic
        lo, hi = current_window(q2d, p)
        i = smin(smax(i, lo), hi)
    volt = p.resistance * i + emf
    mech = kt * i * q2d
    elec = volt * i
    dyn = [(_target_current(u[0], tripped, p) / ip - x[0]) / p.tau_current, mech, elec,
           p.resistance * i * i, smax(-elec, 0.0)]
    h_next = smax(0.0, h + p.driver_period * (i * i - p.i_cont ** 2))
    trip_next = if_then_else(h_next >= interlock_budget(p), 1.0,
                             if_then_else(h_next <= 0.0, 0.0, tripped))
    return SymbolicVectorSystem(state=x, input=u, dynamics=dyn,
                                output=[kt * i, i, volt, emf, mech, elec, h_next, trip_next])


#: output rows of the motor's ``electrics`` (its ``MotorDriver`` ports)
ELECTRIC_OUTPUTS = ("torque", "current", "voltage", "back_emf", "power", "electrical_power")


class MotorDriver(Diagram):
    """Motor and driver as a diagram of C++ systems (no Python runs):

    * ``electrics`` (symbolic): the current loop, which follows the target
      current of the command (:func:`current_command`) with the time
      constant ``tau_current``, clipped to the voltage envelope at the
      elbow's present rate, the winding voltage, the back-EMF, the powers
      and their integrals (mechanical work, electrical energy, copper loss,
      regenerated energy), and the i^2 t interlock's next state
      (:func:`_electrics`);
    * ``driver`` (a zero-order hold at ``driver_period``): the interlock's
      state ``(h, tripped)``, updated from the measured current every
      ``driver_period``.

    Inputs ``torque_command`` (1) and ``state`` (4, the plant state);
    outputs ``torque`` (delivered elbow torque), ``current`` (A),
    ``voltage`` and ``back_emf`` (V), ``power`` (tau q2d, W),
    ``electrical_power`` (V i, W), ``tripped`` (1 while the driver limits
    to i_cont) and ``available`` (the current limit's torque).  The
    delivered torque follows the command through the current loop's state:
    a command changes its rate, not its value."""

    def __init__(self, params: MotorParams):
        from pydrake.systems.framework import DiagramBuilder
        from pydrake.systems.primitives import (AffineSystem, Demultiplexer, Gain,
                                                Multiplexer, Saturation, ZeroOrderHold)

        super().__init__()
        self.params = params
        b = DiagramBuilder()
        elec = b.AddNamedSystem("electrics", _electrics(params))
        driver = b.AddNamedSystem("driver", ZeroOrderHold(params.driver_period, 2))
        n = len(ELECTRIC_OUTPUTS)
        split = b.AddSystem(Demultiplexer([1] * n + [2]))
        held = b.AddSystem(Demultiplexer(2))
        mux = b.AddSystem(Multiplexer([1, 2, 4]))
        b.ExportInput(mux.get_input_port(0), "torque_command")
        b.ExportInput(mux.get_input_port(2), "state")
        b.Connect(driver.get_output_port(0), mux.get_input_port(1))
        b.Connect(mux.get_output_port(0), elec.get_input_port(0))
        b.Connect(elec.get_output_port(0), split.get_input_port(0))
        b.Connect(split.get_output_port(n), driver.get_input_port(0))
        b.Connect(driver.get_output_port(0), held.get_input_port(0))
        for k, name in enumerate(ELECTRIC_OUTPUTS):
            b.ExportOutput(split.get_output_port(k), name)
        b.ExportOutput(held.get_output_port(1), "tripped")
        # the current limit's torque of the held trip state, no feedthrough
        # (a controller's anti-windup reads it): min(torque_limit, kt i_lim),
        # i_lim = i_peak + tripped (i_cont - i_peak)
        limit = b.AddSystem(AffineSystem(D=[[params.i_cont - params.i_peak]],
                                         y0=[params.i_peak]))
        torque = b.AddSystem(Gain(params.torque_per_amp, 1))
        cap = b.AddSystem(Saturation([-np.inf], [params.torque_limit]))
        b.Connect(held.get_output_port(1), limit.get_input_port(0))
        b.Connect(limit.get_output_port(0), torque.get_input_port(0))
        b.Connect(torque.get_output_port(0), cap.get_input_port(0))
        b.ExportOutput(cap.get_output_port(0), "available")
        b.BuildInto(self)

    def interlock_state(self, context) -> tuple[float, bool]:
        """``(h, tripped)`` in ``context`` (root): the i^2 t integral (A^2 s)
        and the trip flag."""
        own = self.GetSubsystemByName("driver").GetMyContextFromRoot(context)
        h, tripped = own.get_discrete_state_vector().CopyToVector()
        return float(h), bool(tripped > 0.5)

    def set_interlock_state(self, context, h: float, tripped: bool) -> None:
        """Start from ``(h, tripped)`` in ``context`` (root): a driver carried
        over from earlier work."""
        own = self.GetSubsystemByName("driver").GetMyMutableContextFromRoot(context)
        own.get_mutable_discrete_state_vector().SetFromVector(
            [float(h), 1.0 if tripped else 0.0])

    def energies(self, context) -> dict:
        """The integrals since the start of ``context`` (J): the motor's
        mechanical work at the elbow, the electrical energy drawn (net), the
        copper loss and the energy regenerated into the supply."""
        sys = self.GetSubsystemByName("electrics")
        v = sys.GetMyContextFromRoot(context).get_continuous_state_vector().CopyToVector()
        return {"mechanical_J": float(v[1]), "electrical_J": float(v[2]),
                "copper_J": float(v[3]), "regenerated_J": float(v[4])}


def max_torque(p: MotorParams) -> float:
    """Largest torque the motor can deliver (current limit and saturation)."""
    return min(p.torque_limit, p.torque_per_amp * p.i_peak)


__all__ = ["MotorDriver", "duty_cycle_to_current", "current_to_duty_cycle",
           "back_emf", "current_window", "torque_window", "torque_window_of", "no_load_speed",
           "stall_torque", "envelope_curve", "ELECTRIC_OUTPUTS",
           "apply_deadband", "current_command", "interlock_budget", "max_torque",
           "i2t_trace", "i2t_after_rest", "rest_for"]
