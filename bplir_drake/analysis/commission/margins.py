"""What a commissioned robot's plans ask of its motor and supply: the
motor's effective figures, each limit's use, the limit that binds and what
would relieve it, the energy drawn per metre, how hard the robot lands and
what commissioning assumed where the description was silent."""
from __future__ import annotations

import math

import numpy as np

from ...planning.solve import planned_i2t
from ...planning.swing_plan import UNBALANCED_SHARE
from ...params import GripperParams, ImuParams
from ...systems.motor import interlock_budget
from ...systems.plant import gripper_position, gripper_velocity, mass_matrix

#: a limit binds a plan that uses at least this share of what the planner
#: allows it of that limit (the optimum would move with the limit)
BINDING_SHARE = 0.95
#: the gear ratios, as multiples of the robot's own, over which the voltage
#: relief is sought
GEAR_MULTIPLES = np.geomspace(0.25, 4.0, 801)


def motor_figures(params) -> dict:
    """The elbow's effective peak torque (N m: the least of the controller's
    and the motor's limits, the driver's peak current and, with the voltage
    envelope, the supply's stall current), which of them it is, and the
    elbow's no-load rate and its rate at that torque (rad/s)."""
    m, c = params.motor, params.controller
    kt = m.torque_per_amp
    caps = {"controller.torque_limit": c.torque_limit, "motor.torque_limit": m.torque_limit,
            "the driver's peak current motor.i_peak": kt * m.i_peak}
    if m.envelope:
        caps["the supply's stall current"] = kt * m.max_voltage / m.resistance
    source = min(caps, key=caps.get)
    out = dict(peak_torque_Nm=caps[source], peak_torque_from=source)
    if m.envelope:
        ke = m.back_emf_constant * m.gear_ratio
        out |= dict(no_load_rate_rad_s=m.max_voltage / ke,
                    rate_at_peak_torque_rad_s=max(0.0, (m.max_voltage - m.resistance
                                                        * caps[source] / kt) / ke))
    return out


def electric_margins(params, plans) -> dict:
    """The plans' peak voltage, current and i^2 t against the motor's limits."""
    m = params.motor
    ok = _feasible(plans)
    if not ok:
        return {}
    return dict(peak_voltage_V=max(p.peak_voltage for p in ok), max_voltage_V=m.max_voltage,
                peak_current_A=max(p.peak_torque for p in ok) / m.torque_per_amp,
                peak_current_limit_A=m.i_peak,
                i2t_A2s=max(planned_i2t(p, m) for p in ok), i2t_budget_A2s=interlock_budget(m))


def limit_uses(params, plans) -> dict:
    """Each limit's use by the feasible ``plans`` (largest over them): the
    peak torque, voltage, power and the driver's i^2 t, each with its limit
    and the share of it the planner allows; empty without a feasible plan."""
    ok = _feasible(plans)
    if not ok:
        return {}
    m, share = params.motor, params.plan
    uses = dict(torque=(max(p.peak_torque for p in ok), motor_figures(params)["peak_torque_Nm"],
                        share.torque_share, "N m"),
                power=(max(p.peak_power for p in ok), m.power_rating, 1.0, "W"),
                i2t=(max(planned_i2t(p, m) for p in ok), interlock_budget(m), 1.0, "A^2 s"))
    if m.envelope:
        uses["voltage"] = (max(p.peak_voltage for p in ok), m.max_voltage, share.voltage_share,
                           "V")
    return {k: dict(used=u, limit=lim, allowed_share=a, unit=unit, share=u / lim)
            for k, (u, lim, a, unit) in uses.items()}


def _feasible(plans) -> list:
    """The feasible ones of ``plans`` (None: a grid point without a plan)."""
    return [p for p in plans if p is not None and p.feasible]


def binding_limit(params, plans) -> dict | None:
    """The limit that holds the feasible ``plans``: the one they use most
    of, as a share of what the planner allows of it, when that is at least
    :data:`BINDING_SHARE` (None: no limit binds, or no plan)."""
    return _binding(limit_uses(params, plans))


def _binding(uses: dict) -> dict | None:
    """:func:`binding_limit` from the limits' uses (:func:`limit_uses`)."""
    if not uses:
        return None
    name = max(uses, key=lambda k: uses[k]["share"] / uses[k]["allowed_share"])
    u = uses[name]
    if u["share"] < BINDING_SHARE * u["allowed_share"]:
        return None
    return dict(u, name=name)


def gear_for_voltage(params, plans) -> dict | None:
    """The gear ratio that gives the feasible ``plans`` the most headroom
    at their own elbow torque and rate, the larger of their peak winding
    voltage over what the planner allows and their peak current over the
    driver's, made least (a gear k times the robot's draws 1/k of the
    current and k times the back-EMF); with that voltage and current (None
    without the envelope or a plan)."""
    m = params.motor
    ok = _feasible(plans)
    if not ok or not m.envelope:
        return None
    tau = np.concatenate([p.torque for p in ok])
    rate = np.concatenate([p.states[:, 3] for p in ok])
    current = tau / m.torque_per_amp
    emf = m.back_emf_constant * m.gear_ratio * rate
    volts = np.array([np.max(np.abs(m.resistance * current / k + emf * k))
                      for k in GEAR_MULTIPLES])
    amps = float(np.max(np.abs(current))) / GEAR_MULTIPLES
    use = np.maximum(volts / (params.plan.voltage_share * m.max_voltage), amps / m.i_peak)
    best = int(np.argmin(use))
    return dict(gear_ratio=float(GEAR_MULTIPLES[best]) * m.gear_ratio,
                peak_voltage_V=float(volts[best]), peak_current_A=float(amps[best]))


def binding_line(params, plans) -> str:
    """One line naming the limit that binds the plans, the others' use, the
    motor's effective figures and what would relieve it ("" without a plan)."""
    uses = limit_uses(params, plans)
    if not uses:
        return ""
    figures = motor_figures(params)
    bound = _binding(uses)
    said = ", ".join(f"{k} {u['used']:.3g} of {u['limit']:.3g} {u['unit']}"
                     for k, u in uses.items())
    head = (f"the plans use {said} (the elbow's effective peak torque "
            f"{figures['peak_torque_Nm']:.3g} N m, from {figures['peak_torque_from']}"
            + (f"; no-load rate {figures['no_load_rate_rad_s']:.3g} rad/s" if
               "no_load_rate_rad_s" in figures else "") + ")")
    if bound is None:
        return head + f"; no limit binds (none used to {100 * BINDING_SHARE:.0f} % of what the " \
                      "planner allows of it)"
    name = bound["name"]
    line = head + f"; {name} binds"
    m = params.motor
    if name == "voltage":
        line += " (speed-limited)"
        supply = math.ceil(bound["used"] / (BINDING_SHARE * params.plan.voltage_share
                                            * m.voltage_fraction))
        line += f": a supply of {supply:.0f} V would leave the plans the planner's headroom"
        gear = gear_for_voltage(params, plans)
        if gear is not None and gear["peak_voltage_V"] < bound["used"]:
            line += (f", or a {gear['gear_ratio']:.0f}:1 gear (not {m.gear_ratio:g}:1) would bring "
                     f"their peak to {gear['peak_voltage_V']:.1f} V at "
                     f"{gear['peak_current_A']:.1f} A (driver: {m.i_peak:g} A)")
    elif name == "torque":
        line += (" (torque-limited): an elbow of "
                 f"{bound['used'] / (BINDING_SHARE * bound['allowed_share']):.3g} N m would "
                 "leave the plans the planner's headroom")
    return line


def supply_energy(plan) -> float:
    """Energy the driver draws from the supply along ``plan`` (J): the
    winding's power ``(R i + Km N q2') i``, ``i = tau / kt``, where positive
    (the copper's, the motor's and the gearbox's losses included), nothing
    fed back where it is negative; nan for a plan made without the motor's
    voltage envelope."""
    if not plan.emf_per_rate:
        return math.nan
    power = plan.voltage * plan.torque / plan.torque_per_amp
    return float(np.trapezoid(np.maximum(power, 0.0), plan.times))


def effective_mass(params, q, direction) -> float:
    """The robot's mass at its free gripper along the unit ``direction`` at
    pose ``q`` (kg), both joints free: ``1 / (u' J M^-1 J' u)``."""
    p = params.plant
    jac = np.column_stack([gripper_velocity(q, e, p.l1, p.l2) for e in np.eye(2)])
    u = np.asarray(direction, dtype=float)
    return float(1.0 / (u @ jac @ np.linalg.solve(mass_matrix(q, p), jac.T @ u)))


def landing_impact(params, plan, speed: float) -> dict:
    """How hard the robot lands at ``speed`` (m/s, the study's capture
    speed): the effective mass at its gripper along the planned gripper's
    velocity where it enters the capture band of ``plan`` (kg), and the
    impact's kinetic energy (J) and impulse (N s) at that mass and speed."""
    p, band = params.plant, params.gripper.capture_distance
    alpha = math.radians(plan.incline_deg)
    normal = np.array([-math.sin(alpha), math.cos(alpha)])
    heights = np.array([normal @ gripper_position(x[:2], p.l1, p.l2) for x in plan.states])
    late = np.arange(len(heights)) >= len(heights) // 2
    k = int(np.argmax(late & (heights >= -band)))
    q, v = plan.states[k, :2], plan.states[k, 2:]
    vel = gripper_velocity(q, v, p.l1, p.l2)
    u = vel / np.linalg.norm(vel) if np.linalg.norm(vel) > 1e-9 else normal
    mass = effective_mass(params, q, u)
    return dict(effective_mass_kg=mass, capture_speed_mps=speed,
                impact_energy_J=0.5 * mass * speed ** 2, impact_impulse_Ns=mass * speed)


def assumptions(params) -> list[str]:
    """What commissioning took for the robot where its description gives
    the package's defaults: no joint friction, the default robot's IMU
    noise, the default clamp's capture criterion; and how energy and
    impacts are counted."""
    out = []
    f = params.friction
    if f.fv1 == f.fv2 == f.fc1 == f.fc2 == 0.0:
        out.append("no joint friction (the description gives none; fit it with bplir calibrate)")
    imu, di = params.imu, ImuParams()
    if (imu.gyro_sigma, imu.accel_sigma) == (di.gyro_sigma, di.accel_sigma):
        out.append(f"the default robot's IMU noise ({di.gyro_sigma:g} rad/s, "
                   f"{di.accel_sigma:g} m/s^2 a sample)")
    g, dg = params.gripper, GripperParams()
    if (g.capture_distance, g.capture_speed) == (dg.capture_distance, dg.capture_speed):
        out.append(f"the default clamp's capture criterion ({dg.capture_distance:g} m, "
                   f"{dg.capture_speed:g} m/s)")
    out.append("the driver feeds nothing back to the supply")
    out.append("an impact meets both joints free (the motor's rotor inertia not counted)")
    return out


def unbalanced(points) -> list[str]:
    """A line per grid point (a commission's rows) whose plan leaves more
    than :data:`UNBALANCED_SHARE` of the energy it exchanges unaccounted:
    the collocation's coarse steps lend it energy its tracking must find."""
    out = []
    for p in points:
        r = p.energy_residual_share
        if r > UNBALANCED_SHARE:
            kind = "" if p.manoeuvre == "swing" else f" ({p.manoeuvre})"
            kind += "" if p.chosen else " (not chosen)"
            out.append(f"gripper {p.holding}, from {p.start}{kind}, "
                       f"{p.incline_deg:+g} deg, {p.spacing_m:g} m: its energy balance "
                       f"leaves {100 * r:.0f} % of the energy it exchanges unaccounted")
    return out
