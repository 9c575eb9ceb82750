"""The whole parameter set (BplirParams), the swapped robot, the presets and the parameter reference the docs are generated from."""
from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Any
from .blocks import ParameterError, _is_plugin, _range_text
from .robot import FrictionParams, MotorParams, PlantParams, RobotFileParams
from .sensing import EstimatorParams, ImuParams, LineSensorParams
from .control import CONTROLLER_PRESETS, ControllerParams, current_preset_name, PathParams
from .plan import HangingParams, LandingParams, PlanParams
from .scenario import DriveParams, GripperParams, ScenarioParams, TraverseParams


@dataclass(frozen=True)
class BplirParams:
    """Everything one run needs.  ``plant``/``friction`` are the nominal
    model; ``true_plant``/``true_friction`` (optional) are the simulated robot."""

    robot: RobotFileParams = field(default_factory=RobotFileParams)
    plant: PlantParams = field(default_factory=PlantParams)
    friction: FrictionParams = field(default_factory=FrictionParams)
    motor: MotorParams = field(default_factory=MotorParams)
    imu: ImuParams = field(default_factory=ImuParams)
    estimator: EstimatorParams = field(default_factory=EstimatorParams)
    controller: ControllerParams = field(default_factory=ControllerParams)
    path: PathParams = field(default_factory=PathParams)
    plan: PlanParams = field(default_factory=PlanParams)
    hanging: HangingParams = field(default_factory=HangingParams)
    landing: LandingParams = field(default_factory=LandingParams)
    scenario: ScenarioParams = field(default_factory=ScenarioParams)
    gripper: GripperParams = field(default_factory=GripperParams)
    drive: DriveParams = field(default_factory=DriveParams)
    traverse: TraverseParams = field(default_factory=TraverseParams)
    line_sensor: LineSensorParams = field(default_factory=LineSensorParams)
    true_plant: PlantParams | None = None
    true_friction: FrictionParams | None = None
    preset_name: str = "dissertation"
    #: the fields a file or ``--set`` gave ("block.field"), which no rule
    #: in the robot's units moves (:func:`~.follow.follow`)
    given: frozenset = field(default=frozenset(), compare=False, repr=False)

    def __post_init__(self):
        if (self.imu.r1 > (self.true_plant or self.plant).l1
                or self.imu.r2 > (self.true_plant or self.plant).l2):
            p = self.true_plant or self.plant
            raise ParameterError(
                f"imu.r1 = {self.imu.r1:g} m / imu.r2 = {self.imu.r2:g} m must lie on "
                f"the links; allowed (0, {p.l1:g}] / (0, {p.l2:g}] m")
        band = self.gripper.capture_distance
        for block, name, h, rest in (
                ("landing", "shoot_height", -self.landing.shoot_height, False),
                ("landing", "shoot_lift_height", -self.landing.shoot_lift_height, False),
                ("plan", "end_depth", self.plan.end_depth, True)):   # the plan comes to rest
            if h > band or (rest and h == band):
                raise ParameterError(
                    f"{block}.{name} = {getattr(getattr(self, block), name):g} m lies below the "
                    f"capture band; allowed within gripper.capture_distance = {band:g} m of "
                    "the line")
        if self.estimator.r1 > self.estimator.l1:
            raise ParameterError(
                f"estimator.r1 = {self.estimator.r1:g} m exceeds estimator.l1 = "
                f"{self.estimator.l1:g} m; allowed (0, l1]")

    @property
    def simulated_plant(self) -> PlantParams:
        """The plant the simulator uses: ``true_plant`` or the nominal one."""
        return self.true_plant if self.true_plant is not None else self.plant

    @property
    def simulated_friction(self) -> FrictionParams:
        """The friction the simulator uses: ``true_friction`` or the nominal one."""
        return self.true_friction if self.true_friction is not None else self.friction

    def with_(self, **blocks) -> "BplirParams":
        """A copy with whole blocks replaced."""
        return replace(self, **blocks)

    def resolved(self) -> "BplirParams":
        """A copy whose ``path.mode`` is concrete (:meth:`PathParams.resolved`)."""
        path = self.path.resolved(self.scenario.incline_deg, self.controller)
        return self if path is self.path else replace(self, path=path)

    def with_controller(self, name: str, args=()) -> "BplirParams":
        """The controller preset ``name``; the ``lab`` firmware also brings its
        own path (``path.mode = "lab"``), the others keep the path block.  A
        ``module:factory`` name, or a registered plug-in's name, plugs in a
        user's controller (``controller.plugin``, its factory called with the
        keyword arguments ``args``, ``"key=value"`` each; the preset's
        parameters stay as they are)."""
        name = current_preset_name(name)
        if name not in CONTROLLER_PRESETS and _is_plugin(name):
            return replace(self, controller=replace(self.controller, plugin=name,
                                                    plugin_args=tuple(args)))
        path = replace(self.path, mode="lab") if name == "lab" else self.path
        # the published robots sense the line with their IMUs alone
        sensor = self.line_sensor if name == "plan" else replace(self.line_sensor, fitted=False)
        return replace(self, controller=ControllerParams.preset_named(name), path=path,
                       line_sensor=sensor)

    def with_estimator(self, spec: str, args=()) -> "BplirParams":
        """A user's estimator ``"module:factory"`` (or a registered name) in the
        swing (``estimator.plugin``, its factory called with the keyword
        arguments ``args``) instead of the EKF; ``""`` restores the EKF."""
        return replace(self, estimator=replace(self.estimator, plugin=spec,
                                               plugin_args=tuple(args) if spec else ()))


def swapped_plant(p: PlantParams) -> PlantParams:
    """The plant seen from the other gripper: link 2 becomes the holding link
    and link 1 the swinging one.  Lengths, masses and inertias trade places;
    each centre of mass is measured from the other end of its link
    (``lc1' = l2 - lc2``, ``lc2' = l1 - lc1``), and with the link's axis
    turned by pi an offset from the axis changes sign (``oc1' = -oc2``)."""
    return replace(p, m1=p.m2, m2=p.m1, l1=p.l2, l2=p.l1, lc1=p.l2 - p.lc2,
                   lc2=p.l1 - p.lc1, oc1=-p.oc2, oc2=-p.oc1, I1=p.I2, I2=p.I1)


def swapped_imu(imu: ImuParams, plant: PlantParams) -> ImuParams:
    """The IMUs seen from the other gripper: IMU 2 (on link 2, ``r2`` from the
    elbow) is the new IMU 1 at ``l2 - r2`` from the new holding gripper, IMU 1
    the new IMU 2 at ``l1 - r1`` from the elbow; each error follows its IMU
    (a misalignment is an angle in the link's frame, which turns by pi with
    the link's direction and keeps its value)."""
    return replace(imu, r1=plant.l2 - imu.r2, r2=plant.l1 - imu.r1,
                   gyro_bias1=imu.gyro_bias2, gyro_bias2=imu.gyro_bias1,
                   misalign1=imu.misalign2, misalign2=imu.misalign1,
                   accel_scale1=imu.accel_scale2, accel_scale2=imu.accel_scale1,
                   gyro_scale1=imu.gyro_scale2, gyro_scale2=imu.gyro_scale1)


def swapped(params: BplirParams) -> BplirParams:
    """The robot holding with the gripper of link 2 (every second swing of a
    traversal), derived from ``params``: the nominal and the simulated plant
    swapped (:func:`swapped_plant`), the simulated IMUs moved with their links
    (:func:`swapped_imu`, true link lengths), the estimator's geometry from the
    nominal model (``l1' = l2``, ``r1' = l2 - r2``, ``r2' = l1 - r1``).
    Friction stays: both wrists are the same joint hardware.  ``swapped``
    twice gives ``params`` back when the estimator's ``l1`` is the nominal
    link length (the dissertation preset; the lab firmware's 0.8 m is not)."""
    nominal, true = params.plant, params.true_plant
    est = params.estimator
    return replace(
        params, plant=swapped_plant(nominal),
        true_plant=None if true is None else swapped_plant(true),
        imu=swapped_imu(params.imu, params.simulated_plant),
        estimator=replace(est, l1=nominal.l2, r1=nominal.l2 - est.r2, r2=est.l1 - est.r1))


def parameter_reference(blocks=None) -> list[dict[str, Any]]:
    """One row per parameter of the default set (``blocks``: the block names
    to list, default all but the simulated robot's copies): block, name,
    unit, allowed range, default and one-line meaning."""
    base = BplirParams()
    names = blocks or [b for b in BLOCKS if not b.startswith("true_")]
    rows = []
    for block in names:
        if block not in BLOCKS or block.startswith("true_"):
            raise ParameterError(f"unknown parameter block '{block}'; allowed: "
                                 + ", ".join(b for b in BLOCKS if not b.startswith("true_")))
        value = getattr(base, block)
        for f in fields(value):
            md = f.metadata
            default = getattr(value, f.name)
            if "lo" in md:
                allowed = _range_text(dict(md, unit=""))
            elif isinstance(default, bool):
                allowed = "true, false"
            else:
                allowed = md.get("allowed", "")
            rows.append({"block": block, "name": f.name, "unit": md.get("unit", ""),
                         "range": allowed, "default": default, "doc": md.get("doc", "")})
    return rows


BLOCKS = {
    "robot": RobotFileParams, "plant": PlantParams, "friction": FrictionParams, "motor": MotorParams,
    "imu": ImuParams, "estimator": EstimatorParams, "controller": ControllerParams,
    "path": PathParams, "plan": PlanParams, "hanging": HangingParams, "landing": LandingParams,
    "scenario": ScenarioParams, "gripper": GripperParams, "drive": DriveParams,
    "traverse": TraverseParams, "line_sensor": LineSensorParams,
    "true_plant": PlantParams, "true_friction": FrictionParams,
}


# ---------------------------------------------------------------- presets
def _dissertation() -> BplirParams:
    return BplirParams(preset_name="dissertation")


def _lab() -> BplirParams:
    """The lab prototype: the estimator geometry of the firmware (r1 = r2 =
    0.5 m, l1 = 0.8 m while the calibrated link is 0.9091 m) and the firmware
    controller (the lab firmware of the dissertation's robot)."""
    return BplirParams(
        estimator=EstimatorParams(r1=0.5, r2=0.5, l1=0.8),
        controller=ControllerParams.preset_named("lab"),
        line_sensor=LineSensorParams(),
        preset_name="lab",
    )


PRESETS = {"dissertation": _dissertation, "lab": _lab}


def preset(name: str = "dissertation") -> BplirParams:
    """A named parameter set: ``dissertation`` (Table 4.3) or ``lab``."""
    try:
        return PRESETS[name]()
    except KeyError:
        raise ParameterError(
            f"unknown preset '{name}'; allowed: " + ", ".join(PRESETS)) from None
