"""Plan tracking's parameters: the planned swing and its tracking
(``plan``), and the landing laws that end it (``landing``)."""
from __future__ import annotations

from dataclasses import dataclass, field, fields

from .blocks import MAX_LENGTH, ParameterError, _Block, _count, _fraction, _p, _positive
import warnings
from .retired import MOVED, relocate

PLAN_INDEXING = ("time", "state")
PLAN_FILE_ANGLES = ("package", "robot")
LANDING_LAWS = ("auto", "shoot", "aim", "reach", "none")
#: the most a landing's aim is raised or lowered (``landing.landing_bias``, m)
MAX_LANDING_BIAS = 0.02


@dataclass(frozen=True)
class PlanParams(_Block):
    """A swing planned by trajectory optimisation on the nominal model and
    tracked by a time-varying LQR (``path.mode = "plan"``): where the plan
    ends, how much of the motor's voltage it may use, which spacings get
    plans of their own, how the tracker reads it (by the clock, or by the
    phase nearest the estimate) and how it finds the loop's delay."""

    _name = "plan"
    end_depth: float = _p(0.015, "m", 0, 0.1, doc="the planned swing comes to rest this far below the line, inside the capture band, so the band is entered slowly")
    voltage_share: float = _fraction(0.9, doc="share of the driver's largest voltage the plan may use at its knots (the rest is the feedback's headroom)")
    torque_share: float = _fraction(1.0, doc="share of the torque limit the plan may use (the rest is the feedback's headroom)")
    spacing_step: float = _p(0.01, "m", 0, 0.1, doc="plans are made for the measured grip spacing rounded to this step, so a study drawing the spacing solves few plans (0: exact)")
    library: bool = field(default=True, metadata=dict(doc="a scenario the shipped plan library of its nominal robot covers gets its plan and gains interpolated from it, in milliseconds (false: every plan solved)"))
    warm_spacing: float = _p(1.2, "m", 0, 2 * MAX_LENGTH, lo_open=True, off="none", doc="a plan for another spacing is also solved from this spacing's plan and the cheaper one kept (none: straight-line guesses only)")
    indexing: str = field(default="time", metadata=dict(doc="time (the plan read by the clock) or state (the plan phase nearest the estimate: no clock)", allowed="time, state"))
    delay_compensation: float = _p(0.01, "s", 0, 0.1, doc="actuation delay the tracker assumes until it has identified one (whole periods; the lab firmware's 10 ms)")
    delay_probe: float = _p(10.0, "N m", 0, 20, doc="amplitude of the delay probe, two opposite doublets on the first eight commands whose gyro echo identifies the delay (0: none)")
    delay_max: float = _p(0.03, "s", 0.01, 0.1, doc="with delay_probe: the longest actuation delay the identification considers (whole periods)")
    delay_window: int = _count(12, "ticks", 8, 50, doc="with delay_probe: the ticks of gyro samples the identification fits (12: 120 ms from the release)")
    delay_min_ratio: float = _p(1.25, "", 1, 100, doc="the identified delay is used only if the runner-up candidate fits the gyros this many times worse")
    file: str = field(default="", metadata=dict(doc="CSV of a plan made elsewhere (time, state, torque) the swing tracks instead of the planner's (relative to the config file; '' : the planner's)", allowed="a CSV path or ''"))
    file_columns: tuple = field(default=("t", "q1", "q2", "q1d", "q2d", "tau"), metadata=dict(doc="the plan file's columns of time (s), q1, q2 (rad), q1', q2' (rad/s) and elbow torque (N m), in that order", allowed="six column names"))
    file_angles: str = field(default="package", metadata=dict(doc="the plan file's angles, rates and torque are the package's (package) or the joint coordinates of the robot description (robot)", allowed="package, robot"))
    lqr_state: tuple = field(default=(100.0, 100.0, 10.0, 10.0), metadata=dict(doc="the tracking LQR's weights on the errors of q1, q2 (1/rad^2) and q1', q2' (s^2/rad^2)", allowed="four numbers >= 0"))
    lqr_torque: float = _p(0.1, "1/(N m)^2", 0, lo_open=True, doc="the tracking LQR's weight on the torque")
    lqr_final: float = _p(10.0, "", 0, doc="the tracking LQR's weight on the plan's final state, times lqr_state")

    def _check(self):
        self._one_of("indexing", PLAN_INDEXING)
        self._one_of("file_angles", PLAN_FILE_ANGLES)
        if len(self.file_columns) != 6 or not all(isinstance(c, str) and c
                                                  for c in self.file_columns):
            raise ParameterError(f"plan.file_columns = {list(self.file_columns)} must be six "
                                 "column names (time, q1, q2, q1', q2', torque)")
        twice = sorted({c for c in self.file_columns if self.file_columns.count(c) > 1})
        if twice:
            raise ParameterError(f"plan.file_columns = {list(self.file_columns)} names "
                                 f"{', '.join(twice)} more than once; allowed: six different "
                                 "columns (time, q1, q2, q1', q2', torque)")
        w = self.lqr_state
        if len(w) != 4 or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                  and 0 <= v < float("inf") for v in w):
            raise ParameterError(f"plan.lqr_state = {list(w)} must be four numbers; allowed: "
                                 "each >= 0 and finite")


@dataclass(frozen=True)
class HangingParams(_Block):
    """How a swing from hanging at rest (``scenario.start = "hanging"``: a
    traversal's try again) is planned: it pumps for seconds before it
    reaches, so its plan may keep more headroom than a swing from the line."""

    _name = "hanging"
    torque_share: float = _fraction(1.0, doc="share of the torque limit the plan may use, at most plan.torque_share (the rest is the tracker's headroom over a pump of seconds)")
    supply_voltage: float = _p("motor", "V", 0, 100, lo_open=True, off="motor", doc="supply voltage whose envelope the plan keeps to (motor: motor.supply_voltage; a lower one paces the pump below what the robot's supply allows)")
    i2t_share: float = _p("none", "", 0, 1, lo_open=True, off="none", doc="share of the driver's i^2 t budget the plan may use by itself from a reset driver; a guess whose plan uses more gives way to the next, and the least heating feasible plan is kept if none keeps to it (none: the first feasible guess)")


@dataclass(frozen=True)
class LandingParams(_Block):
    """How plan tracking ends the swing on the line, by the law's name: the
    shooting landing (``shoot``: link 1's stop aimed at the line), the aim
    law (``aim``: the elbow lifts the gripper to a margin below it), the
    terminal reach (``reach``), or ``none`` (the plan tracked to its end);
    ``auto`` picks between the first two on the plan."""

    _name = "landing"
    # the terminal reach (systems/landing.py), off by default
    reach_speed: float = _p(0.0, "m/s", 0, 2, doc="landing_law 'reach': the speed toward its aim the reach's profile starts from")
    reach_depth: float = _p(0.12, "m", 0, 0.5, doc="the reach takes over once the gripper is this close to the line in the plan's second half (or at the plan's end)")
    reach_lift: float = _p(-0.01, "m", -0.1, 0.1, doc="the reach aims the gripper this far from the line (negative: below, inside the capture band)")
    reach_brake: float = _positive(1.25, "m/s^2", doc="the reach's speed profile toward its aim, sqrt(reach_speed^2 + 2 reach_brake |distance|)")
    reach_tangent: float = _p(0.25, "m/s", 0, 10, lo_open=True, off="never", doc="while the gripper slides along the line faster than this the reach holds it reach_hold from the line")
    reach_hold: float = _p(-0.05, "m", -0.2, 0, doc="see reach_tangent")
    reach_rate_gain: float = _positive(30.0, "1/s", doc="the reach's speed error to acceleration gain")
    # the apex landing (systems/landing.py)
    landing_lead: float = _p(0.025, "m s/rad", 0, 1, lo_open=True, doc="the aim law aims landing_margin + landing_lead q1' below the line, so the gripper meets the band as link 1 stops")
    landing_margin: float = _p(0.01, "m", 0, 0.1, doc="the landing aims the gripper this far below the line when link 1 stops (inside the capture band)")
    landing_depth: float = _p(0.12, "m", 0, 0.5, doc="the aim law takes over once the gripper is this close to the line in the plan's last forward swing of link 1")
    landing_take_rate: float = _p(1.2, "rad/s", 0, 10, doc="... or once link 1 slows below this rate while decelerating")
    landing_gain: float = _positive(10.0, "1/s", doc="the landing's height error to rate gain")
    landing_rate_gain: float = _positive(30.0, "1/s", doc="the landing's rate error to acceleration gain")
    landing_min_decel: float = _positive(1.0, "rad/s^2", doc="link 1 counts as decelerating above this (nominal model, elbow held)")
    landing_law: str = field(default="auto", metadata=dict(doc="plan tracking's terminal law: auto (shoot where link 1 carries the gripper to the line, aim where the elbow lifts it), shoot, aim, reach (the terminal reach) or none (the plan tracked to its end)", allowed="auto, shoot, aim, reach, none"))
    landing_bias: float = _p(0.0, "m", -MAX_LANDING_BIAS, MAX_LANDING_BIAS, doc="how far the robot's estimate of the gripper's height ran above the truth at earlier landings; both landing laws aim this much higher")
    shoot_height: float = _p(-0.015, "m", -0.1, 0, doc="landing_law 'shoot': the gripper's aimed distance to the line when link 1 stops (negative: inside the capture band, at most gripper.capture_distance deep)")
    shoot_depth: float = _p(0.3, "m", 0, 1, doc="landing_law 'shoot': it takes over once the gripper is this close to the line in the plan's last forward swing of link 1")
    shoot_min_time: float = _p(0.04, "s", 0.02, 0.5, doc="landing_law 'shoot': with less time to link 1's stop, or link 1 slower than shoot_min_rate, the stop time is held at this")
    shoot_min_rate: float = _p(0.02, "rad/s", 0, 5, doc="landing_law 'shoot': with link 1 slower than this the shot's stop time is held at shoot_min_time")
    lift_law: str = field(default="aim", metadata=dict(doc="landing_law 'auto': the law where the plan lifts the gripper with the elbow (downhill): aim, or shoot (held from shoot_lift_min_time, aimed at shoot_lift_height)", allowed="aim, shoot"))
    shoot_lift_min_time: float = _p(0.05, "s", 0, 0.5, lo_open=True, doc="lift_law 'shoot': shoot_min_time where the plan lifts the gripper with the elbow")
    shoot_lift_height: float = _p(-0.019, "m", -0.1, 0, doc="lift_law 'shoot': shoot_height where the plan lifts the gripper with the elbow (see shoot_lift_min_time; at most gripper.capture_distance deep)")
    shoot_hold_depth: float = _p(0.03, "m", 0, 1, doc="landing_law 'shoot': the stop time is held at shoot_min_time only within this of the aimed height")
    shoot_give_up_rate: float = _p(0.1, "rad/s", 0, 5, lo_open=True, off="never", doc="landing_law 'shoot': once link 1 swings back faster than this with the gripper below its aim, the shot brakes the elbow and gives up")
    shoot_brake_ratio: float = _p("never", "", 0, 10, lo_open=True, off="never", doc="landing_law 'shoot': a shot asking for more than this multiple of the torque the motor can give at the elbow's rate to lift the gripper towards the line brakes the elbow instead (never: it never does)")
    shoot_rate_cap: float = _p(0.3, "rad/s", 0, 5, lo_open=True, off="none", doc="landing_law 'shoot': within shoot_hold_depth of the aimed height the shot brakes the elbow back to this rate where it would turn it faster (the elbow's rate is most of the gripper's speed at capture; none: no cap)")
    shoot_link1_share: float = _p(0.5, "", 0, 1, doc="landing_law 'auto': the shot where link 1 makes at least this share of the planned gripper's rise rate near the line, else the lift rule")

    def _check(self):
        self._one_of("landing_law", LANDING_LAWS)
        self._one_of("lift_law", ("aim", "shoot"))


#: fields of the former ``[path]`` table that are now in ``[plan]`` (by
#: their new names) or ``[landing]`` (same names)
MOVED_TO_PLAN = {f"plan_{f.name}": f.name for f in fields(PlanParams)}
MOVED_TO_LANDING = {f.name: f.name for f in fields(LandingParams)}


def moved_field(block: str, name: str) -> tuple[str, str]:
    """Where ``block.name`` lives now: a former ``path.plan_*`` field in
    ``plan``, a former ``path`` landing field in ``landing``, a field moved
    since (:data:`~.retired.MOVED`); any other unchanged."""
    if block == "path" and name in MOVED_TO_PLAN:
        return "plan", MOVED_TO_PLAN[name]
    if block == "path" and name in MOVED_TO_LANDING:
        return "landing", name
    return MOVED.get((block, name), (block, name))


def split_path_table(data: dict) -> dict:
    """``data`` (tables by block) with a former ``[path]`` table's plan and
    landing fields moved to ``[plan]`` and ``[landing]`` (a table the data
    gives itself wins), with one ``FutureWarning`` naming the move."""
    path = data.get("path")
    if not isinstance(path, dict):
        return data
    out, moved = relocate(data, {("path", k): moved_field("path", k) for k in path
                                 if moved_field("path", k)[0] != "path"})
    if moved:
        warnings.warn("the [path] table's plan tracking fields are now in [plan] (without the "
                      "plan_ prefix) and [landing]", FutureWarning, stacklevel=3)
    return out
