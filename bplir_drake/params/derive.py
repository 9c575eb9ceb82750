"""What a manoeuvre runs with: :func:`derive` is the one answer.

A robot (its ``BplirParams`` as a file, Python or the command line gives
them) does a :class:`Manoeuvre`: it starts on the line or hanging, holds
with gripper 1 or 2, reaches the line in one swing or by pumping, on a line
of some incline and grip spacing, as a single swing, a traversal's step or
a try again from hanging.  ``derive(robot, manoeuvre, hardware)`` gives the
parameters it runs with: the robot's rules in its units
(:func:`~.follow.follow`), the hardware options in those units
(:func:`with_hardware`), then the manoeuvre's rules, each a constant of
this module in the robot's time unit ``sqrt(L/g)``, its capture band or
its reach.  Apply it to the robot held by gripper 1, never to what it
returned.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from types import SimpleNamespace

from .blocks import ParameterError
from .control import HARDWARE_OPTIONS, IMU_ONLY_TUNING, LINE_SENSOR_OPTION, SUPPLY_48V_OPTION
from .follow import follow, followed, in_units, robot_scales
from .model import BLOCKS, BplirParams, preset, swapped
from .plan import MAX_LANDING_BIAS
from .robot import line_pose

#: where a manoeuvre starts, how it reaches the line, in what context it is done
STARTS, REACHES, CONTEXTS = ("line", "hanging"), ("swing", "pump"), ("single", "traverse", "retry")

#: a pumping manoeuvre's timeout, the longest its plan may take, in the
#: robot's time unit sqrt(L/g) (9.4 s on the default robot)
PUMP_TIME = 20.0

#: a traversal's swing comes to rest this share of the capture band below
#: the line (13 mm of the default clamp's 20 mm), deeper than a single
#: swing's ``plan.end_depth``: between obstacles it must land on its grip
TRAVERSE_END_SHARE = 0.65

#: a try again from hanging pumps before it reaches: its timeout in the
#: robot's time unit sqrt(L/g) (6.0 s on the default robot)
RETRY_TIME = 12.8

#: where a try's plan lifts the gripper with the elbow, the apex shot is held
#: from this, in the robot's time unit (50 ms on the default robot), instead
#: of the aim law, which chases the line as link 1 falls back
RETRY_LIFT_HOLD = 0.107

#: a try ends at the line where the robot's free link ends within this of
#: upright on a level line (turning it there lifts the gripper at under half
#: the speed it moves it, so the shot cannot make up a pump that falls short)
UPRIGHT_FREE_LINK = math.radians(30.0)


@dataclass(frozen=True)
class Manoeuvre:
    """What the robot does.  ``gripper``: the holding gripper (2: the robot
    seen from its other gripper); ``start``: ``"line"`` or ``"hanging"``
    (None: the robot's ``scenario.start``); ``reach``: ``"swing"`` (one
    swing) or ``"pump"`` (None: ``scenario.manoeuvre``); ``incline_deg``,
    ``spacing`` (m): its line (None: the scenario's); ``context``:
    ``"single"``, ``"traverse"`` (a traversal's swing: incline rounded to
    0.1 deg, spacing to 1 mm, so a line's plans are a few) or ``"retry"``
    (a traversal's swing tried again from hanging); ``end_at_line``: a
    try's plan ends at the line (None: where the free link ends upright,
    :func:`free_link_upright`); ``learnt``: the landing height errors (m)
    of the earlier captures holding with the same gripper, which a
    traversal's swing aims ``traverse.landing_learning`` of higher;
    ``raised``: how many tries before this one timed out with the robot's
    estimate of the gripper in the capture band (each aims
    ``traverse.retry_aim_raise`` higher)."""

    gripper: int = 1
    start: str | None = None
    reach: str | None = None
    incline_deg: float | None = None
    spacing: float | None = None
    context: str = "single"
    end_at_line: bool | None = None
    learnt: tuple = ()
    raised: int = 0

    def __post_init__(self):
        checks = (("gripper", self.gripper, (1, 2)), ("start", self.start, STARTS + (None,)),
                  ("reach", self.reach, REACHES + (None,)),
                  ("context", self.context, CONTEXTS))
        for name, value, allowed in checks:
            if value not in allowed:
                raise ParameterError(f"manoeuvre {name} = {value!r}; allowed: "
                                     + ", ".join(str(a) for a in allowed if a is not None))
        if self.raised < 0:
            raise ParameterError(f"manoeuvre raised = {self.raised}; allowed >= 0")


def derive(robot: BplirParams, manoeuvre: Manoeuvre | None = None,
           hardware=()) -> BplirParams:
    """The parameters ``robot`` does ``manoeuvre`` with (default: its own
    single swing), with the ``hardware`` options (names of
    :data:`~.control.HARDWARE_OPTIONS`, in any order)."""
    m = manoeuvre or Manoeuvre()
    p = with_hardware(follow(robot, preset(robot.preset_name)), *hardware)
    if m.gripper == 2:
        p = swapped(p)
    sc = p.scenario
    start = m.start or ("hanging" if m.context == "retry" else sc.start)
    reach = m.reach or ("swing" if start == "hanging" else sc.manoeuvre_of(m.gripper))
    if reach == "pump" and start != "line":
        raise ParameterError(f"a pumping manoeuvre starts on the line; start = '{start}' is "
                             "not allowed with it (a swing from hanging pumps by its own plan)")
    spacing = sc.grip_spacing if m.spacing is None else float(m.spacing)
    incline = sc.incline_deg if m.incline_deg is None else float(m.incline_deg)
    if m.context != "single":
        spacing, incline = round(spacing, 3), round(incline, 1)
    p = p.with_(scenario=replace(sc, grip_spacing=spacing, incline_deg=incline, start=start,
                                 manoeuvre="swing"))
    if m.context != "single":
        p = _traverse_swing(p, m, pumps=reach == "pump")
    if reach == "pump":
        p = _pumping(p)
    if m.context == "retry":
        p = _retry(p, m)
    return p


def _traverse_swing(p: BplirParams, m: Manoeuvre, pumps: bool = False) -> BplirParams:
    """A traversal's swing (``traverse.swing_mode = "plan"``): tracked
    without the terminal reach (it lands where the gripper first moves
    slowly, sliding along the line if it must, where a traversal has to land
    on its grip between obstacles), resting :data:`TRAVERSE_END_SHARE` of
    the band below the line, landing as a single swing does (by
    ``landing.landing_law``, with the delay probe and its compensation),
    its shot braking at
    ``traverse.shoot_brake_ratio`` where that is set, and aiming
    ``traverse.landing_learning`` of the mean landing height error it
    learnt (:attr:`Manoeuvre.learnt`) higher.  A traversal's pump (``pumps``)
    comes to rest where the robot's own pump does: its plans are the ones
    commissioning verified."""
    tp = p.traverse
    if tp.swing_mode != "plan":
        return p
    plan = p.plan if pumps else replace(
        p.plan, end_depth=round(TRAVERSE_END_SHARE * p.gripper.capture_distance, 6))
    landing = p.landing
    if landing.landing_law == "reach":   # a traversal's swing lands by the apex laws or none
        landing = replace(landing, landing_law="none")
    if tp.shoot_brake_ratio != "landing":
        landing = replace(landing, shoot_brake_ratio=tp.shoot_brake_ratio)
    errors = [e for e in m.learnt if math.isfinite(e)]
    if tp.landing_learning > 0.0 and errors and landing.landing_law != "none":
        mean = sum(errors) / len(errors)
        landing = replace(landing, landing_bias=_bias(tp.landing_learning * mean))
    return p.with_(path=replace(p.path, mode="plan"), plan=plan, landing=landing)


def _bias(b: float) -> float:
    return min(MAX_LANDING_BIAS, max(-MAX_LANDING_BIAS, b))


def _pumping(p: BplirParams) -> BplirParams:
    """Reaching the next grip from the line by pumping: the swing's timeout
    at least :data:`PUMP_TIME` of the robot's time unit."""
    sc = p.scenario
    timeout = max(sc.max_time, round(PUMP_TIME * robot_scales(p.plant)[0], 2))
    return p.with_(scenario=replace(sc, manoeuvre="pump", max_time=timeout))


def _retry(p: BplirParams, m: Manoeuvre) -> BplirParams:
    """The swing tried again from hanging at rest below the holding
    gripper: :data:`RETRY_TIME` to arrive; its plan ends at the line where
    the free link ends upright (:attr:`Manoeuvre.end_at_line`); where its
    plan lifts the gripper with the elbow, the apex shot held from
    :data:`RETRY_LIFT_HOLD` lands it; each earlier try that timed out with
    the estimate in the band (:attr:`Manoeuvre.raised`) aims it
    ``traverse.retry_aim_raise`` higher (the estimate ran above the truth
    there and does so again on the same manoeuvre)."""
    t0 = robot_scales(p.plant)[0]
    p = p.with_(scenario=replace(p.scenario, max_time=round(RETRY_TIME * t0, 2)))
    at_line = free_link_upright(p) if m.end_at_line is None else m.end_at_line
    if at_line:
        p = p.with_(plan=replace(p.plan, end_depth=0.0))
    hold = max(round(RETRY_LIFT_HOLD * t0, 3), 2 * p.controller.period)
    landing = replace(p.landing, lift_law="shoot", shoot_lift_min_time=hold)
    if m.raised:
        landing = replace(landing, landing_bias=_bias(
            landing.landing_bias + m.raised * p.traverse.retry_aim_raise))
    return p.with_(landing=landing)


def raises_aim(p: BplirParams, summary) -> bool:
    """Whether the try from hanging ``p`` that ended with ``summary`` (its
    swing's :class:`~bplir_drake.analysis.swing.summary.SwingSummary`) teaches the next try to aim higher
    (:attr:`Manoeuvre.raised`): it timed out with the robot's estimate of
    the gripper within the capture band (the jaw would have sensed the
    line).  A swing from the line ends its pump-less reach differently and
    teaches nothing here."""
    return (p.traverse.retry_aim_raise > 0.0 and p.scenario.start == "hanging"
            and summary.outcome == "timeout"
            and summary.estimated_peak_height_m >= -p.gripper.capture_distance)


def free_link_tilt(p: BplirParams, spacing: float | None = None) -> float:
    """How far (rad) the free link of the robot ``p`` stands from upright
    in its end pose on a level line at ``spacing`` (default
    ``traverse.grip_spacing``; the nominal model's, elbow below the line)."""
    q1, q2 = line_pose(p.traverse.grip_spacing if spacing is None else spacing, p.plant)
    free = (q1 + q2 + math.pi) % (2.0 * math.pi) - math.pi   # 0: hanging down
    return math.pi - abs(free)


def free_link_upright(p: BplirParams) -> bool:
    """Whether the free link of ``p`` ends within :data:`UPRIGHT_FREE_LINK`
    of upright on a level line at ``traverse.grip_spacing``."""
    return free_link_tilt(p) < UPRIGHT_FREE_LINK


def planned_from_hanging(p: BplirParams) -> BplirParams:
    """``p`` as its plan from hanging is made with: ``plan.torque_share``
    at most ``hanging.torque_share``, and the motor at
    ``hanging.supply_voltage`` unless that is the motor's own (the robot
    swings at its own supply; only the plan keeps to the other's envelope)."""
    pl, motor, h = p.plan, p.motor, p.hanging
    if h.supply_voltage != "motor":
        motor = replace(motor, supply_voltage=h.supply_voltage)
    return p.with_(motor=motor, plan=replace(pl, torque_share=min(pl.torque_share,
                                                                  h.torque_share)))


def as_planned(p: BplirParams) -> BplirParams:
    """``p`` as the planner makes its plan: from hanging, within its own
    torque share and supply (:func:`planned_from_hanging`); else ``p``."""
    return planned_from_hanging(p) if p.scenario.start == "hanging" else p


def on_line(p: BplirParams, incline_deg: float, spacing: float) -> BplirParams:
    """The manoeuvre ``p`` (as :func:`derive` gave it) on another line: this
    incline (deg) and grip spacing (m), a point of its plan grid; nothing
    else is derived again (the robot may already be seen from its other
    gripper, whose units are not the description's)."""
    return p.with_(scenario=replace(p.scenario, incline_deg=float(incline_deg),
                                    grip_spacing=float(spacing)))


def with_hardware(p: BplirParams, *names: str) -> BplirParams:
    """``p`` with the named hardware options (:data:`HARDWARE_OPTIONS`, in
    any order; their settings are the default robot's, put in ``p``'s
    units): ``"line-sensor"`` (the jaw's line range sensor and the landing's
    aim with it, :data:`LINE_SENSOR_OPTION`), ``"48v"`` (a 48 V supply, its
    swings from hanging planned as the 30 V robot plans them, and a
    traversal's landing shot braking where far out of reach,
    :data:`SUPPLY_48V_OPTION`)."""
    ref = preset(p.preset_name)
    for name in names:
        if name == "line-sensor":
            o = dict(LINE_SENSOR_OPTION)
            p = p.with_(line_sensor=replace(p.line_sensor, fitted=True, range=o.pop("range")),
                        landing=replace(p.landing, **in_units(p, ref, "landing", o)))
        elif name == "48v":
            o = SUPPLY_48V_OPTION
            p = p.with_(motor=replace(p.motor, supply_voltage=o["supply_voltage"]),
                        hanging=replace(p.hanging, supply_voltage=o["hanging_supply_voltage"]),
                        traverse=replace(p.traverse, shoot_brake_ratio=o["shoot_brake_ratio"]))
        else:
            raise ParameterError(f"unknown hardware option '{name}'; allowed: "
                                 + ", ".join(HARDWARE_OPTIONS))
    return p


def imu_only(p: BplirParams) -> BplirParams:
    """``p`` without the jaw's line sensor (``line_sensor.fitted`` false:
    the IMUs alone), with the shooting landing's aim of that robot
    (:data:`IMU_ONLY_TUNING`, in ``p``'s units)."""
    ref = preset(p.preset_name)
    return p.with_(line_sensor=replace(p.line_sensor, fitted=False),
                   landing=replace(p.landing, **in_units(p, ref, "landing", IMU_ONLY_TUNING)))


def around(plant, friction=None) -> BplirParams:
    """The default parameters around another robot's links ``plant`` (and
    its ``friction``, kept as given; default the default robot's in the
    robot's units), every rule followed (:func:`~.follow.follow`)."""
    base = BplirParams()
    given = frozenset(f"friction.{n}" for n in ("fv1", "fv2", "fc1", "fc2", "b")) \
        if friction is not None else frozenset()
    blocks = {b: getattr(base, b) for b in BLOCKS} | {"plant": plant,
                                                       "friction": friction or base.friction}
    blocks |= followed(SimpleNamespace(**blocks), base, given)
    return replace(base, **blocks, given=given)
