"""A two-link brachiator from its URDF or SDFormat description.

Drake's ``Parser`` reads the file into a ``MultibodyPlant``; the joints
and the free gripper named in ``[robot]`` pick the brachiator out of it.
A planar two-link robot's dynamics about parallel joint axes are fully
given by each link's length (joint to joint, or elbow to gripper), mass,
centre of mass in the plane of motion and inertia about the joint axis
through it, so the reader extracts exactly those (:class:`PlantParams`,
the centre of mass off the link's axis included) and says how the file's
joint angles map to the package's (``q1`` from the downward vertical,
``q2`` relative, counter-clockwise seen along the pivot's axis).
:func:`~bplir_drake.systems.plant.description_residual` compares the closed form of the extracted
parameters with the parsed plant's mass matrix, bias and gravity terms.

Everything a link carries welded to it (a hook, an IMU board) counts as
part of that link; a body welded to the world does not move and is
ignored.  A joint's damping is its viscous friction (``friction.fv1``,
``fv2`` unless the config gives them); joint limits are not modelled (a
swing does not reach them); a reflected rotor inertia is refused.  Lengths, masses and inertias are rounded to 12 significant
digits: a description's numbers are decimal, and the rounding removes
the ~1e-16 noise of the frame transforms, so a robot read from a file
and the same robot typed into ``[plant]`` are one model (and share cached
plans).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .blocks import ParameterError
from .robot import PlantParams
from .robot_check import check_description

#: descriptions shipped with the package, by the name ``robot.file`` may give
SHIPPED_ROBOTS = {"bplir": "bplir.urdf"}

#: the suffixes Drake's parser reads
ROBOT_SUFFIXES = (".urdf", ".sdf")


def shipped_robot_path(name: str) -> Path:
    """The path of a shipped description (:data:`SHIPPED_ROBOTS`)."""
    return Path(__file__).resolve().parent.parent / "data" / "robots" / SHIPPED_ROBOTS[name]


def resolve_robot_file(file: str, base_dir: Path | None = None) -> Path:
    """``robot.file`` as a path: a shipped name, or a path (relative ones
    from ``base_dir``, the config file's directory); a missing file or an
    unknown suffix raises :class:`ParameterError`."""
    if file in SHIPPED_ROBOTS:
        return shipped_robot_path(file)
    path = Path(file).expanduser()
    if not path.is_absolute() and base_dir is not None:
        path = Path(base_dir) / path
    if path.suffix.lower() not in ROBOT_SUFFIXES:
        raise ParameterError(f"robot.file = '{file}' is not a robot description; allowed: a "
                             f"{' or '.join(ROBOT_SUFFIXES)} file or "
                             + ", ".join(SHIPPED_ROBOTS))
    if not path.is_file():
        raise ParameterError(f"robot.file = '{file}': no such file ({path})")
    return path.resolve()


@dataclass(frozen=True)
class RobotDescription:
    """What a description says: the plant (package conventions), and the
    map from the file's joint angles to the package's, ``q1 = q1_file +
    offset[0]``, ``q2 = sign2 q2_file + offset[1]`` (the same sign for the
    elbow's rate and torque)."""

    path: str
    plant: PlantParams
    offset: tuple[float, float]
    sign2: float
    damping: tuple[float, float] = (0.0, 0.0)   # the joints' viscous damping (N m s/rad)

    def from_file_state(self, x):
        """Rows ``(q1, q2[, q1d, q2d])`` in the file's joint coordinates -> the package's."""
        x = np.array(x, dtype=float)
        x[..., 0] += self.offset[0]
        x[..., 1] = self.sign2 * x[..., 1] + self.offset[1]
        if x.shape[-1] == 4:
            x[..., 3] *= self.sign2
        return x

    def to_file_state(self, x):
        """The inverse of :meth:`from_file_state`."""
        x = np.array(x, dtype=float)
        x[..., 0] -= self.offset[0]
        x[..., 1] = self.sign2 * (x[..., 1] - self.offset[1])
        if x.shape[-1] == 4:
            x[..., 3] *= self.sign2
        return x


def _round(x: float) -> float:
    return float(f"{x:.12g}")


def parse_description(path: Path):
    """A finalized ``MultibodyPlant`` of the file (geometry left out)."""
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    check_description(path)   # what Drake would warn about and substitute
    plant = MultibodyPlant(0.0)
    parser = Parser(plant)
    parser.SetStrictParsing()   # any other warning of the parser is an error too
    try:
        parser.AddModels(file_name=str(path))
    except (RuntimeError, ValueError) as exc:   # Drake's parser errors are long; the first line
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else "unreadable"
        raise ParameterError(f"robot.file {path}: {first}") from None
    plant.Finalize()
    return plant


def _revolute(plant, name: str, role: str):
    from pydrake.multibody.tree import RevoluteJoint

    names = [plant.get_joint(j).name() for j in plant.GetJointIndices()]
    revolute = [n for n in names if isinstance(plant.GetJointByName(n), RevoluteJoint)]
    if name not in names:
        raise ParameterError(f"robot.{role} = '{name}' is not a joint of the file; its revolute "
                             "joints: " + ", ".join(revolute))
    joint = plant.GetJointByName(name)
    if not isinstance(joint, RevoluteJoint):
        raise ParameterError(f"robot.{role} = '{name}' is not a revolute joint; allowed: "
                             + ", ".join(revolute))
    return joint


def _frame(plant, name: str):
    from pydrake.multibody.tree import FrameIndex

    frames = [plant.get_frame(FrameIndex(i)).name() for i in range(plant.num_frames())]
    if name not in frames:
        raise ParameterError(f"robot.free_gripper = '{name}' is not a frame or link of the file; "
                             "allowed: " + ", ".join(f for f in frames if f))
    return plant.GetFrameByName(name)


def _link(plant, context, bodies, origin, axis_dir, basis, axis):
    """(mass, along, across, inertia) of the welded ``bodies`` with the link's
    axis ``axis_dir`` (unit, plane) from ``origin`` (world point)."""
    spatial = plant.CalcSpatialInertia(context, plant.world_frame(),
                                       [b.index() for b in bodies])
    m = spatial.get_mass()
    if not m > 0.0:
        raise ParameterError("robot.file: a link has no mass; allowed: a mass > 0 on each link")
    com = spatial.get_com()
    central = spatial.Shift(com).CalcRotationalInertia().CopyToFullMatrix3()
    inertia = float(axis @ central @ axis)
    r = basis @ (np.asarray(com) - origin)
    normal = np.array([-axis_dir[1], axis_dir[0]])
    return m, float(r @ axis_dir), float(r @ normal), inertia


def read_description(path: Path, pivot_joint: str, elbow_joint: str,
                     free_gripper: str) -> RobotDescription:
    """The :class:`RobotDescription` of the file at ``path`` with the named
    joints and gripper frame."""
    plant = parse_description(path)
    context = plant.CreateDefaultContext()   # every joint at zero: the file's reference pose
    if plant.num_positions() != 2:
        raise ParameterError(f"robot.file {path} moves {plant.num_positions()} joint "
                             "coordinates; allowed: 2 (a two-link brachiator)")
    pivot = _revolute(plant, pivot_joint, "pivot_joint")
    elbow = _revolute(plant, elbow_joint, "elbow_joint")
    gravity = np.asarray(plant.gravity_field().gravity_vector(), dtype=float)
    g = float(np.linalg.norm(gravity))
    X_p = pivot.frame_on_child().CalcPoseInWorld(context)
    X_e = elbow.frame_on_child().CalcPoseInWorld(context)
    axis = X_p.rotation().matrix() @ pivot.revolute_axis()
    axis2 = X_e.rotation().matrix() @ elbow.revolute_axis()
    if g == 0.0 or abs(axis @ gravity) > 1e-9 * g or abs(abs(axis @ axis2) - 1.0) > 1e-9:
        raise ParameterError(f"robot.file {path}: the joints' axes must be parallel and "
                             "horizontal (a planar brachiator swinging under gravity)")
    up = -gravity / g
    basis = np.vstack([np.cross(up, axis), up])      # the plane's x (along the line) and y (up)
    origin = X_p.translation()
    elbow_at = X_e.translation()
    grip_at = _frame(plant, free_gripper).CalcPoseInWorld(context).translation()
    u1, u2 = basis @ (elbow_at - origin), basis @ (grip_at - elbow_at)
    l1, l2 = float(np.hypot(*u1)), float(np.hypot(*u2))
    if not (l1 > 0.0 and l2 > 0.0):
        raise ParameterError(f"robot.file {path}: the elbow or the free gripper sits on the "
                             "joint before it; allowed: links of length > 0")
    link1 = plant.GetBodiesWeldedTo(pivot.child_body())
    link2 = plant.GetBodiesWeldedTo(elbow.child_body())
    if elbow.parent_body().index() not in {b.index() for b in link1}:
        raise ParameterError(f"robot.elbow_joint = '{elbow_joint}' does not join link 1 "
                             f"(after '{pivot_joint}'); allowed: the joint after the pivot")
    m1, lc1, oc1, I1 = _link(plant, context, link1, origin, u1 / l1, basis, axis)
    m2, lc2, oc2, I2 = _link(plant, context, link2, elbow_at, u2 / l2, basis, axis)
    theta1, theta2 = math.atan2(u1[0], -u1[1]), math.atan2(u2[0], -u2[1])
    values = dict(m1=m1, m2=m2, l1=l1, l2=l2, lc1=lc1, lc2=lc2, oc1=oc1, oc2=oc2, I1=I1, I2=I2,
                  g=g)
    plant_params = PlantParams(**{k: _round(v) for k, v in values.items()})
    _refuse_rotor_inertia(plant, path)
    return RobotDescription(str(path), plant_params,
                            (_round(theta1), _round(math.remainder(theta2 - theta1, 2 * math.pi))),
                            float(np.sign(axis @ axis2)),
                            (float(pivot.default_damping()), float(elbow.default_damping())))


def _refuse_rotor_inertia(plant, path) -> None:
    """A motor's reflected rotor inertia (``drake:rotor_inertia``) adds to
    the elbow's inertia alone, which the two links' parameters cannot
    express: refused rather than dropped."""
    for i in plant.GetJointActuatorIndices():
        actuator = plant.get_joint_actuator(i)
        reflected = actuator.default_rotor_inertia() * actuator.default_gear_ratio() ** 2
        if reflected != 0.0:
            raise ParameterError(f"robot.file {path}: actuator '{actuator.name()}' has a "
                                 f"reflected rotor inertia ({reflected:g} kg m^2), which the "
                                 "package does not model; allowed: none")


@functools.lru_cache(maxsize=16)
def _cached(path: str, mtime: float, pivot: str, elbow: str, gripper: str) -> RobotDescription:
    return read_description(Path(path), pivot, elbow, gripper)


def describe_robot(robot, base_dir: Path | None = None) -> RobotDescription:
    """The description ``robot`` (a :class:`RobotFileParams`) names, read once per file version."""
    path = resolve_robot_file(robot.file, base_dir)
    return _cached(str(path), path.stat().st_mtime, robot.pivot_joint, robot.elbow_joint,
                   robot.free_gripper)

