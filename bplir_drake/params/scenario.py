"""What one swing and one traversal face: the line's geometry, success thresholds, disturbances and seeds; the wrist-wheel drive and the traversal's settings."""
from __future__ import annotations

import numbers
from dataclasses import dataclass, field
from .blocks import MAX_LENGTH, ParameterError, _Block, _count, _fraction, _length, _p, _positive
from .plan import MAX_LANDING_BIAS


# ---------------------------------------------------------------- scenario
#: where a swing starts (``scenario.start``)
SWING_STARTS = ("line", "hanging", "plan")
#: how a swing from the line reaches the next grip (``scenario.manoeuvre``)
MANOEUVRES = ("swing", "pump")


@dataclass(frozen=True)
class ScenarioParams(_Block):
    """One swing: geometry of the line, thresholds of success, noise seeds."""

    _name = "scenario"
    grip_spacing: float = _positive(1.2, "m", doc="distance D between the grippers on the line")
    incline_deg: float = _p(0.0, "deg", -90, 90, lo_open=True, hi_open=True,
                            doc="line incline (positive: rising in the direction of travel)")
    max_time: float = _p(3.0, "s", 0, 60, lo_open=True, doc="timeout of one swing")
    min_travel_fraction: float = _p(0.8, "", 0, 2, lo_open=True, doc="arrival must be at least this fraction of D along the line")
    friction_uncertainty: float = _p(0.2, "", 0, 0.99, doc="simulated friction drawn within +/- this fraction of nominal")
    wind_torque1: float = _p(0.0, "N m", -20, 20, doc="constant external torque on joint 1 (wind)")
    wind_torque2: float = _p(0.0, "N m", -20, 20, doc="constant external torque on joint 2 (wind)")
    gust_torque: float = _p(0.0, "N m", 0, 20, doc="peak torque of random gusts on each joint")
    gust_rate: float = _p(0.0, "1/s", 0, 100, doc="mean number of gusts per second (Poisson)")
    gust_duration: float = _p(0.1, "s", 0, 1, lo_open=True, doc="duration of one gust")
    torque_noise: float = _p(0.0, "N m", 0, 20, doc="white noise on the applied elbow torque (per controller period)")
    actuation_delay: float = _p(0.0, "s", 0, 0.2, doc="extra delay of the torque command (whole controller periods)")
    seed: int = field(default=0, metadata=dict(doc="seed of the swing's random draws (sensor noise, gusts, the simulated friction)", allowed="[0, 2^32)"))
    use_estimator: bool = field(default=True, metadata=dict(doc="the controller reads the EKF's estimate (false: the true state sampled at its tick)"))
    wall_limit: float = _p(300.0, "s", 0, 86400, lo_open=True, doc="wall-clock time one swing may take before it is stopped as a fault (a hung plug-in); not physics")
    start: str = field(default="line", metadata=dict(doc="where the swing starts: line (both grippers on the line), hanging (at rest below the holding gripper; plan tracking only) or plan (the first state of plan.file, rates included)", allowed="line, hanging, plan"))

    manoeuvre: str = field(default="swing", metadata=dict(doc="how a plan-tracked swing from the line reaches the next grip: swing (one swing of link 1 at most) or pump (link 1 swings back and forth as often as its plan needs, planned on more knots); two, comma-separated, for the robot holding with gripper 1 and with gripper 2 (what its commissioning chose)", allowed="swing, pump, or one per gripper: swing,pump"))

    def manoeuvres(self) -> list[str]:
        """``manoeuvre``'s entries (one, or one per gripper)."""
        return [m.strip() for m in self.manoeuvre.split(",")]

    def manoeuvre_of(self, gripper: int = 1) -> str:
        """How the robot holding with ``gripper`` reaches the next grip from
        the line (``manoeuvre``'s entry for it)."""
        parts = self.manoeuvres()
        return parts[min(gripper, len(parts)) - 1]

    def _check(self):
        self._one_of("start", SWING_STARTS)
        parts = self.manoeuvres()
        if len(parts) > 2 or any(m not in MANOEUVRES for m in parts):
            raise ParameterError(f"scenario.manoeuvre = '{self.manoeuvre}' is unknown; allowed: "
                                 "swing, pump, or one per gripper: swing,pump")
        if "pump" in parts and self.start != "line":
            raise ParameterError(f"scenario.manoeuvre = 'pump' starts on the line; "
                                 f"scenario.start = '{self.start}' is not allowed with it "
                                 "(a swing from hanging pumps by its own plan)")
        checked_seed(self.seed, "scenario.seed")


#: seeds are 32-bit (what NumPy's and Drake's generators take)
SEED_LIMIT = 2 ** 32


def checked_seed(seed, name: str = "seed") -> int:
    """``seed`` as an int, or ``ParameterError`` naming ``name`` unless it is
    a whole number in [0, 2^32) (a bool or a numeral string is not)."""

    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) \
            or not 0 <= seed < SEED_LIMIT:
        raise ParameterError(f"{name} = {seed!r} is not a seed; allowed a whole number in "
                             "[0, 2^32)")
    return int(seed)


# ---------------------------------------------------------------- traversal
TRAVERSE_SWING_MODES = ("plan", "adaptive")


@dataclass(frozen=True)
class GripperParams(_Block):
    """The free gripper taking the line: its capture criterion, a property of
    the robot.  An active clamp (the default robot's jaw) closes on the line
    once the gripper comes within ``capture_distance`` of it, at up to
    ``capture_speed``; a passive hook takes the bar within its throat at up
    to the speed it withstands.  Both grippers are alike."""

    _name = "gripper"
    capture_distance: float = _length(0.02, doc="gripper-to-line distance at which the gripper takes the line (the capture band)")
    capture_speed: float = _positive(0.5, "m/s", doc="largest gripper speed at which it takes the line (faster is a crash)")
    width: float = _p(0.08, "m", 0, 0.5, doc="length of line a clasped gripper covers")


@dataclass(frozen=True)
class DriveParams(_Block):
    """The wrist-wheel drive that rides the line between obstacles (ours: the
    dissertation names the wheels, chapter 1, but gives no drive data).  A
    trapezoidal speed profile within the speed, acceleration and power limits;
    rolling resistance and the climb are paid at ``efficiency``, nothing is
    recovered downhill."""

    _name = "drive"
    max_speed: float = _p(0.3, "m/s", 0, 2, lo_open=True, doc="riding speed limit")
    max_accel: float = _p(0.2, "m/s^2", 0, 5, lo_open=True, doc="riding acceleration limit")
    rolling_resistance: float = _p(0.02, "", 0, 0.5, doc="rolling resistance coefficient of the wheels on the conductor")
    efficiency: float = _fraction(0.6, doc="electrical-to-mechanical efficiency of the wheel drive")
    power_limit: float = _positive(60.0, "W", doc="largest electrical power of the wheel drive (limits the speed uphill)")
    standby_power: float = _p(5.0, "W", 0, 200, doc="electronics (IMUs, controller, radio) at all times")
    adjust_speed: float = _p(0.05, "m/s", 0, 1, lo_open=True, doc="speed of one wheel setting the grip spacing while the other gripper clamps")


@dataclass(frozen=True)
class TraverseParams(_Block):
    """Crossing a stretch of line (``bplir traverse``): the grip spacing every
    swing is set up at, the margins the planner keeps to obstacles, how swings
    are controlled and when the robot rests for the driver's i^2 t budget."""

    _name = "traverse"
    grip_spacing: float = _p(1.2, "m", 0, 2 * MAX_LENGTH, lo_open=True, doc="grip spacing every swing is set up at (the swing lands about this far ahead of the holding gripper)")
    spacing_min: float = _p(0.9, "m", 0, 2 * MAX_LENGTH, lo_open=True, doc="shortest grip spacing the route may choose for a swing where the set-up spacing does not fit between obstacles")
    spacing_max: float = _p(1.5, "m", 0, 2 * MAX_LENGTH, lo_open=True, doc="longest grip spacing the route may choose for a swing (the reach; wider obstacles need it)")
    clearance: float = _p(0.05, "m", 0, 1, doc="gap kept between a clasped gripper and an obstacle")
    landing_tolerance: float = _p(0.08, "m", 0, 1, doc="planned landings lie at least this much further from obstacles (the swing's landing error)")
    swing_mode: str = field(default="plan", metadata=dict(doc="how traversal swings are steered: plan (plan tracking) or the path generator (adaptive)", allowed="plan, adaptive"))
    # swing_mode 'plan': the single swing's apex landing and delay compensation
    # (landing.landing_*, plan.delay_compensation) on every traversal swing
    landing_learning: float = _p(0.5, "", 0, 1, doc="each swing aims this share of the mean landing height error of the earlier captures holding with the same gripper higher (0: no learning)")
    rest: bool = field(default=True, metadata=dict(doc="rest before a swing, and before a try again, until the driver's i^2 t state allows the planned swing"))
    i2t_margin: float = _p(0.2, "", 0, 0.9, doc="share of the driver's i^2 t budget a swing may not use: the planner rests until the planned swing keeps this share free")
    max_incline_deg: float = _p(25.0, "deg", 0, 60, doc="steepest line incline accepted in a line file")
    retries: int = _count(2, "", 0, 5, doc="swings tried again after a timeout, each from hanging at rest (0: a timeout ends the traversal)")
    shoot_brake_ratio: float = _p("landing", "", 0, 10, lo_open=True, off="landing", doc="landing.shoot_brake_ratio of the traversal's swings (landing: the landing's own)")
    retry_aim_raise: float = _p(0.005, "m", 0, MAX_LANDING_BIAS, doc="after a try from hanging that timed out with the robot's estimate of the gripper within the capture band (the estimate ran above the truth), the next try aims this much higher")
    recover_limit: float = _p(240.0, "s", 1, 3600, doc="longest the robot damps its swing after a timeout before it gives up")
    recover_energy: float = _p(0.05, "J", 0, 10, lo_open=True, doc="the swing counts as damped when its energy above hanging at rest is below this")
    recover_kp: float = _p(20.0, "N m/rad", 0, 1000, doc="stiffness of the elbow's damping law tau = kp (lean q1' - q2) - kd q2'")
    recover_kd: float = _p(3.0, "N m s/rad", 0, 1000, doc="damping of the elbow's damping law")
    recover_lean: float = _p(-0.3, "s", -2, 2, doc="elbow angle per shoulder rate the damping law aims at (it bends the elbow against the swing)")

    def _check(self):
        if not self.spacing_min <= self.grip_spacing <= self.spacing_max:
            raise ParameterError(
                f"traverse.grip_spacing = {self.grip_spacing:g} m is outside [spacing_min, "
                f"spacing_max] = [{self.spacing_min:g}, {self.spacing_max:g}] m; allowed "
                "spacing_min <= grip_spacing <= spacing_max")
        self._one_of("swing_mode", TRAVERSE_SWING_MODES)
