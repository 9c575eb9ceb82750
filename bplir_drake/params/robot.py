"""The robot's body and drive: the two links (Table 4.3), the joint friction, the motor, gearbox and driver (Table 4.2)."""
from __future__ import annotations

import math
from pathlib import Path
from dataclasses import dataclass, field, replace
from .blocks import (MAX_LENGTH, MAX_MASS, MAX_RESISTANCE, ParameterError, _Block, _fraction,
                     _length, _p, _positive)

#: the largest inertia of a link about its centre of mass (kg m^2): the
#: heaviest link spread over the longest
MAX_INERTIA = MAX_MASS * MAX_LENGTH ** 2


# ---------------------------------------------------------------- plant
@dataclass(frozen=True)
class PlantParams(_Block):
    """Rigid-body parameters of the two-link acrobot (Table 4.3)."""

    _name = "plant"
    m1: float = _p(3.2287, "kg", 0, MAX_MASS, lo_open=True, doc="mass of link 1 (gripper-side link)")
    m2: float = _p(1.5155, "kg", 0, MAX_MASS, lo_open=True, doc="mass of link 2 (free link)")
    l1: float = _length(0.9091, doc="length of link 1 (pivot to elbow)")
    l2: float = _length(1.2451, doc="length of link 2 (elbow to free gripper)")
    lc1: float = _p(0.2167, "m", 0, MAX_LENGTH, doc="pivot to centre of mass of link 1")
    lc2: float = _p(0.5459, "m", 0, MAX_LENGTH, doc="elbow to centre of mass of link 2")
    oc1: float = _p(0.0, "m", -MAX_LENGTH, MAX_LENGTH,
                    doc="centre of mass of link 1 off its axis (pivot to elbow), "
                        "positive counter-clockwise of it")
    oc2: float = _p(0.0, "m", -MAX_LENGTH, MAX_LENGTH,
                    doc="centre of mass of link 2 off its axis (elbow to free gripper), "
                        "positive counter-clockwise of it")
    I1: float = _p(0.1539, "kg m^2", 0, MAX_INERTIA, lo_open=True, doc="inertia of link 1 about its CoM")
    I2: float = _p(0.2191, "kg m^2", 0, MAX_INERTIA, lo_open=True, doc="inertia of link 2 about its CoM")
    g: float = _p(9.81, "m/s^2", 0, 30, lo_open=True, doc="gravitational acceleration")

    @property
    def rc1(self) -> float:
        """Distance (m) from the pivot to link 1's centre of mass."""
        return math.hypot(self.lc1, self.oc1)

    @property
    def rc2(self) -> float:
        """Distance (m) from the elbow to link 2's centre of mass."""
        return math.hypot(self.lc2, self.oc2)

    @property
    def dc1(self) -> float:
        """Angle (rad) from link 1's axis to its centre of mass, counter-clockwise."""
        return math.atan2(self.oc1, self.lc1)

    @property
    def dc2(self) -> float:
        """Angle (rad) from link 2's axis to its centre of mass, counter-clockwise."""
        return math.atan2(self.oc2, self.lc2)

    def gravity_link1(self) -> tuple[float, float]:
        """``(G, phase)`` with ``G sin(q1 + phase)`` the gravity torque of
        link 1's own mass and of link 2's mass at the elbow about the pivot
        (N m): ``g (m1 rc1 sin(q1 + dc1) + m2 l1 sin q1)``."""
        a = self.g * (self.m1 * self.lc1 + self.m2 * self.l1)
        b = self.g * self.m1 * self.oc1
        return math.hypot(a, b), math.atan2(b, a)

    def key_dict(self) -> dict:
        """The fields as a dict, the off-axis offsets only when set (the key
        of cached plans, which predate them)."""
        d = self.as_dict()
        for name in ("oc1", "oc2"):
            if d[name] == 0.0:
                del d[name]
        return d

    def _check(self):
        if self.lc1 > self.l1:
            raise ParameterError(
                f"plant.lc1 = {self.lc1:g} m exceeds plant.l1 = {self.l1:g} m; "
                f"allowed [0, l1]")
        if self.lc2 > self.l2:
            raise ParameterError(
                f"plant.lc2 = {self.lc2:g} m exceeds plant.l2 = {self.l2:g} m; "
                f"allowed [0, l2]")


# ---------------------------------------------------------------- friction
@dataclass(frozen=True)
class FrictionParams(_Block):
    """Joint friction (4.10)/(4.11) per joint: viscous, Coulomb, drag.

    The drag term is ``0.5*rho_air*cd*area_i*qd*|qd|`` (a lumped coefficient;
    the dissertation gives no values, so the areas default to zero: the
    Table 4.3 calibration already lumps drag into fv and fc).
    """

    _name = "friction"
    fv1: float = _p(0.1706, "N m s/rad", 0, doc="viscous friction, joint 1 (gripper)")
    fv2: float = _p(0.0765, "N m s/rad", 0, doc="viscous friction, joint 2 (elbow)")
    fc1: float = _p(0.0124, "N m", 0, doc="Coulomb friction, joint 1")
    fc2: float = _p(0.7681, "N m", 0, doc="Coulomb friction, joint 2")
    b: float = _p(0.01, "rad/s", 0, 10, lo_open=True,
                  doc="arctan smoothing velocity of (4.11)")
    rho_air: float = _p(1.225, "kg/m^3", 0, doc="air density")
    cd: float = _p(1.0, "", 0, doc="drag coefficient")
    area1: float = _p(0.0, "m^2 (lumped)", 0, doc="effective drag area, joint 1")
    area2: float = _p(0.0, "m^2 (lumped)", 0, doc="effective drag area, joint 2")
    enabled: bool = field(default=True, metadata=dict(doc="joint friction on (false: a frictionless plant)"))

    def drag_coefficients(self) -> tuple[float, float]:
        """(k1, k2) = 0.5 rho Cd A of each joint (N m s^2/rad^2)."""
        k = 0.5 * self.rho_air * self.cd
        return k * self.area1, k * self.area2

    def scaled(self, viscous: float = 1.0, coulomb: float = 1.0) -> "FrictionParams":
        """Both viscous coefficients times ``viscous``, both Coulomb ones
        times ``coulomb``."""
        return self.with_factors((viscous, viscous, coulomb, coulomb))

    def with_factors(self, factors) -> "FrictionParams":
        """``(fv1, fv2, fc1, fc2)`` each times its factor (a perturbed
        friction, e.g. drawn within +/- 20 % as in 3.3)."""
        k = [float(v) for v in factors]
        return replace(self, fv1=self.fv1 * k[0], fv2=self.fv2 * k[1], fc1=self.fc1 * k[2],
                       fc2=self.fc2 * k[3])


# ---------------------------------------------------------------- motor
@dataclass(frozen=True)
class MotorParams(_Block):
    """Motor, gearbox and ESCON 50/5 driver (Table 4.2, (4.12)-(4.14)).

    ``km`` is the motor torque constant.  Table 4.2 prints 0.634 N m/A, which
    would make 15 A worth 456 N m at the output; the datasheet's own stall
    torque / stall current (3.43 N m / 124 A = 0.02766 N m/A) gives 19.9 N m
    at 15 A (the "theoretical 20 N m") and 0.836 N m at the 0.63 A dead-band
    current (the printed 0.82336 N m of (4.14)), so that value is used.
    """

    _name = "motor"
    km: float = _positive(3.43 / 124.0, "N m/A", doc="motor torque constant")
    gear_ratio: float = _positive(74.0, "", doc="gearbox ratio N")
    eta_g: float = _fraction(0.72, doc="gearbox efficiency")
    eta_m: float = _fraction(0.90, doc="motor efficiency")
    i_peak: float = _positive(15.0, "A", doc="driver peak current")
    t_peak: float = _positive(2.675, "s", doc="time the driver holds peak current")
    i_cont: float = _positive(5.0, "A", doc="driver continuous current")
    tau_current: float = _p(0.005, "s", 0, 0.01, lo_open=True,
                            doc="current-loop time constant (<= 10 ms, 4.4)")
    deadband: float = _p(0.82336, "N m", 0, doc="torque dead-band (4.14)")
    torque_limit: float = _p(20.0, "N m", 0, lo_open=True,
                             doc="torque saturation (20 theoretical, 15 practical)")
    power_rating: float = _positive(220.0, "W", doc="motor power rating")
    driver_period: float = _p(0.01, "s", 0, 1, lo_open=True,
                              doc="update period of the driver's i^2 t interlock")
    supply_voltage: float = _p(30.0, "V", 1, 100,
                               doc="supply voltage (Table 4.2: 30 V as built, 48 V nominal)")
    resistance: float = _p(48.0 / 124.0, "ohm", 0, MAX_RESISTANCE, lo_open=True,
                                  doc="winding resistance (Table 4.2: 48 V / 124 A stall)")
    voltage_fraction: float = _fraction(
        0.98, doc="largest driver output voltage / supply (ESCON 50/5 datasheet: 0.98)")
    envelope: bool = field(default=True, metadata=dict(
        doc="the driver's output voltage limits the current (back-EMF and winding resistance)"))

    @property
    def back_emf_constant(self) -> float:
        """Motor back-EMF constant (V s/rad), equal to ``km`` in SI units."""
        return self.km

    @property
    def max_voltage(self) -> float:
        """Largest voltage the driver puts across the motor (V)."""
        return self.voltage_fraction * self.supply_voltage

    def _check(self):
        if self.i_cont > self.i_peak:
            raise ParameterError(
                f"motor.i_cont = {self.i_cont:g} A exceeds motor.i_peak = "
                f"{self.i_peak:g} A; allowed (0, i_peak]")

    @property
    def torque_per_amp(self) -> float:
        """(4.12): tau = Km N eta_g eta_m i."""
        return self.km * self.gear_ratio * self.eta_g * self.eta_m


# ---------------------------------------------------------------- robot file
@dataclass(frozen=True)
class RobotFileParams(_Block):
    """The robot's description file: with ``file`` set, the ``[plant]``
    block is read from it (lengths, masses, centres of mass, inertias,
    gravity); fields a config's ``[plant]`` table gives override the file's."""

    _name = "robot"
    file: str = field(default="", metadata=dict(
        doc="URDF or SDFormat file of the robot (relative to the config file), or the name of "
            "a shipped one ('bplir'); '' : the [plant] block alone",
        allowed="a .urdf or .sdf path, bplir or ''"))
    pivot_joint: str = field(default="gripper_joint", metadata=dict(
        doc="revolute joint at the holding gripper (the passive joint, q1)",
        allowed="a revolute joint of the file"))
    elbow_joint: str = field(default="elbow_joint", metadata=dict(
        doc="revolute joint at the elbow (the actuated joint, q2)",
        allowed="a revolute joint of the file"))
    free_gripper: str = field(default="free_gripper", metadata=dict(
        doc="frame (or link) of the free gripper at the end of link 2",
        allowed="a frame of the file"))


def line_pose(grip_spacing: float, p: PlantParams) -> tuple[float, float]:
    """(q1, q2) rad of the robot ``p`` with both grippers on a level line
    ``grip_spacing`` apart, the free gripper behind the holding one and the
    elbow below the line (the law of cosines; :func:`~bplir_drake.systems.
    plant.initial_configuration` turns it onto an inclined line)."""
    l1, l2, D = p.l1, p.l2, grip_spacing
    lo, hi = abs(l1 - l2), l1 + l2
    if not (lo < D < hi):
        raise ParameterError(
            f"scenario.grip_spacing = {D:g} m is out of reach of the links; "
            f"allowed ({lo:.4g}, {hi:.4g}) m")
    # interior angle at the elbow from the law of cosines
    cos_e = (l1 ** 2 + l2 ** 2 - D ** 2) / (2 * l1 * l2)
    q2 = -(math.pi - math.acos(max(-1.0, min(1.0, cos_e))))
    # angle of link 1 from the downward vertical: gripper at (-D, 0)
    # with q2 < 0 the elbow hangs below the line
    cos_b = (l1 ** 2 + D ** 2 - l2 ** 2) / (2 * l1 * D)
    beta = math.acos(max(-1.0, min(1.0, cos_b)))  # angle at the pivot
    return -(math.pi / 2 - beta), q2


def robot_label(params) -> str:
    """What a figure calls the robot of ``params``: "BPLIR" for the
    dissertation's links, else its description file's name (or "two-link
    robot" for one given by its ``[plant]`` table alone)."""
    if params.plant == PlantParams():
        return "BPLIR"
    file = params.robot.file
    if file and file != "bplir":
        return Path(file).stem
    return "two-link robot"
