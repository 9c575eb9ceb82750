"""The BPLIR acrobot as a Drake ``MultibodyPlant`` plus its closed form.

Conventions (docs/concepts.md): the line is the x axis through the fixed gripper
(origin), y is up, gravity is -y.  ``q1`` is link 1's angle from the downward
vertical (passive joint at the fixed gripper), ``q2`` the elbow angle of link
2 relative to link 1 (actuated).  Both joints rotate about +z, so positive
angles are counter-clockwise in the x-y plane.  Forward kinematics (A.3):
elbow ``(l1 s1, -l1 c1)``, free gripper ``(l1 s1 + l2 s12, -l1 c1 - l2 c12)``.

The closed-form manipulator terms are (4.6)-(4.8) *corrected*: the printed
M21 lacks the ``c2`` factor of M12 and (A.9) leaves ``lc2`` unsquared; the
mass matrix below is symmetric and is tested against the plant.

The pure functions accept floats, ``AutoDiffXd`` or symbolic ``Expression``
(they use ``pydrake.math``), so the controller can call them in any scalar
type.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pydrake.math as dmath

from ..params import PlantParams
from ..params.robot import line_pose
from ..params.robot_file import parse_description

# ----------------------------------------------------------- closed form


def mass_matrix(q, p: PlantParams):
    """M(q) of (4.6), corrected to be symmetric; a centre of mass off its
    link's axis (``oc1``, ``oc2``) turns its term by ``dc1``/``dc2``."""
    c2 = dmath.cos(q[1] + p.dc2)
    r1, r2 = p.rc1, p.rc2
    a = p.I2 + p.m2 * r2 ** 2
    m12 = a + p.m2 * p.l1 * r2 * c2
    m11 = (p.m1 * r1 ** 2 + p.I1 + p.m2 * p.l1 ** 2 + a
           + 2.0 * p.m2 * p.l1 * r2 * c2)
    return np.array([[m11, m12], [m12, a]])


def coriolis_matrix(q, v, p: PlantParams):
    """C(q, v) of (4.7)."""
    h = -p.m2 * p.l1 * p.rc2 * dmath.sin(q[1] + p.dc2)
    return np.array([[h * v[1], h * (v[0] + v[1])], [-h * v[0], 0.0 * h]])


def bias_term(q, v, p: PlantParams):
    """C(q, v) v: Coriolis and centrifugal generalized forces."""
    h = p.m2 * p.l1 * p.rc2 * dmath.sin(q[1] + p.dc2)
    return np.array([-h * (2.0 * v[0] * v[1] + v[1] ** 2), h * v[0] ** 2])


def gravity_vector(q, p: PlantParams):
    """g(q) of (4.8): M qdd + C qd + g = tau - f."""
    s1, s1c = dmath.sin(q[0]), dmath.sin(q[0] + p.dc1)
    s12 = dmath.sin(q[0] + q[1] + p.dc2)
    return np.array([p.m1 * p.g * p.rc1 * s1c + p.m2 * p.g * (p.l1 * s1 + p.rc2 * s12),
                     p.m2 * p.g * p.rc2 * s12])


def potential_energy(q, p: PlantParams):
    """V(q) of (4.4), zero with the links on the line's height."""
    c1, c1c = dmath.cos(q[0]), dmath.cos(q[0] + p.dc1)
    c12 = dmath.cos(q[0] + q[1] + p.dc2)
    return -p.m1 * p.g * p.rc1 * c1c - p.m2 * p.g * (p.l1 * c1 + p.rc2 * c12)


def link_centres_of_mass(q, p: PlantParams):
    """Both links' centres of mass (x, y) in m in the line frame (rows)."""
    e = elbow_position(q, p.l1)
    t1, t12 = q[0] + p.dc1, q[0] + q[1] + p.dc2
    return np.array([[p.rc1 * dmath.sin(t1), -p.rc1 * dmath.cos(t1)],
                     [e[0] + p.rc2 * dmath.sin(t12), e[1] - p.rc2 * dmath.cos(t12)]])


def kinetic_energy(q, v, p: PlantParams):
    """Kinetic energy (J) at (q, v)."""
    v = np.asarray(v)
    return 0.5 * v @ mass_matrix(q, p) @ v


def forward_dynamics(q, v, tau2, f, p: PlantParams):
    """qdd from (4.5) with elbow torque ``tau2`` and friction ``f`` (2-vector)."""
    M = mass_matrix(q, p)
    rhs = np.array([0.0, tau2]) - bias_term(q, v, p) - gravity_vector(q, p) - np.asarray(f)
    det = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
    return np.array([(M[1, 1] * rhs[0] - M[0, 1] * rhs[1]) / det,
                     (-M[1, 0] * rhs[0] + M[0, 0] * rhs[1]) / det])


# ----------------------------------------------------------- kinematics


def elbow_position(q, l1):
    """Elbow position (x, y) in m in the line frame."""
    return np.array([l1 * dmath.sin(q[0]), -l1 * dmath.cos(q[0])])


def gripper_position(q, l1, l2):
    """Free gripper position (A.3) in the line frame (x along the line)."""
    s1, c1 = dmath.sin(q[0]), dmath.cos(q[0])
    s12, c12 = dmath.sin(q[0] + q[1]), dmath.cos(q[0] + q[1])
    return np.array([l1 * s1 + l2 * s12, -l1 * c1 - l2 * c12])


def gripper_velocity(q, v, l1, l2):
    """Free-gripper velocity (m/s) in the line frame."""
    c1, s1 = dmath.cos(q[0]), dmath.sin(q[0])
    c12, s12 = dmath.cos(q[0] + q[1]), dmath.sin(q[0] + q[1])
    w12 = v[0] + v[1]
    return np.array([l1 * c1 * v[0] + l2 * c12 * w12, l1 * s1 * v[0] + l2 * s12 * w12])


def absolute_from_relative(q_rel):
    """(q1, q2[, q1d, q2d]) -> (theta1, theta2[, omega1, omega2]), chapter 5."""
    q_rel = np.asarray(q_rel)
    out = np.array(q_rel, dtype=q_rel.dtype)
    out[..., 1] = q_rel[..., 0] + q_rel[..., 1]
    if q_rel.shape[-1] == 4:
        out[..., 3] = q_rel[..., 2] + q_rel[..., 3]
    return out


def relative_from_absolute(theta):
    """Inverse of :func:`absolute_from_relative`."""
    theta = np.asarray(theta)
    out = np.array(theta, dtype=theta.dtype)
    out[..., 1] = theta[..., 1] - theta[..., 0]
    if theta.shape[-1] == 4:
        out[..., 3] = theta[..., 3] - theta[..., 2]
    return out


def swapped_state(x):
    """The same physical pose seen from the other gripper (the swapped robot
    of a traversal, :func:`bplir_drake.params.swapped`): link 2 pointing from
    its gripper to the elbow is the new link 1, ``q1' = q1 + q2 + pi``
    (wrapped to (-pi, pi]), ``q2' = -q2``; with rates (4-vector) the link
    rates follow, ``q1d' = q1d + q2d``, ``q2d' = -q2d``.  Its own inverse."""
    x = np.asarray(x, dtype=float)
    q1 = math.remainder(x[0] + x[1] + math.pi, 2 * math.pi)
    if q1 == -math.pi:
        q1 = math.pi
    out = [q1, -x[1]]
    if x.shape[-1] == 4:
        out += [x[2] + x[3], -x[3]]
    return np.array(out)


def line_frame(alpha: float):
    """Unit vectors along and normal (upward) to a line inclined by alpha."""
    return (np.array([math.cos(alpha), math.sin(alpha)]),
            np.array([-math.sin(alpha), math.cos(alpha)]))


def initial_configuration(grip_spacing: float, p: PlantParams,
                          incline: float = 0.0) -> np.ndarray:
    """Start configuration with both grippers on the line, elbow below it.

    The fixed gripper is at the origin and the free gripper at distance D
    behind it along a line inclined by ``incline`` (rad; positive rises in
    the direction of travel, +x), i.e. at ``-D (cos a, sin a)``.  With the
    Table 4.3 links and D = 1.2 m this is about (-0.334, -1.997) rad.
    """
    q1, q2 = line_pose(grip_spacing, p)
    return np.array([q1 + incline, q2])


def start_configuration(start: str, grip_spacing: float, p: PlantParams,
                        incline: float = 0.0) -> np.ndarray:
    """The swing's start pose for ``scenario.start``: ``"line"`` both
    grippers on the line (:func:`initial_configuration`), ``"hanging"`` at
    rest straight below the holding gripper (q1 = q2 = 0, whatever the
    incline; the grip spacing and the links are still checked)."""
    q = initial_configuration(grip_spacing, p, incline)
    return q if start == "line" else np.zeros(2)


def target_configuration(grip_spacing: float, p: PlantParams,
                         incline: float = 0.0) -> np.ndarray:
    """Mirror configuration (7.1) about the line's normal through the pivot."""
    q0 = initial_configuration(grip_spacing, p, 0.0)
    return np.array([-q0[0] + incline, -q0[1]])


# ----------------------------------------------------------- Drake plant


def add_acrobot_plant(builder, p: PlantParams, *, scene_graph: bool = False):
    """Add the continuous-time BPLIR ``MultibodyPlant`` to ``builder``.

    The elbow actuator has no effort limit (Drake >= 1.51 would clamp
    silently); saturation lives in the motor model and the controller.
    Returns the finalized plant (and the scene graph when requested).
    """
    from pydrake.multibody.plant import AddMultibodyPlantSceneGraph, MultibodyPlant

    if scene_graph:
        plant, sg = AddMultibodyPlantSceneGraph(builder, 0.0)
    else:
        plant, sg = builder.AddSystem(MultibodyPlant(0.0)), None
    _populate(plant, p, sg)
    plant.Finalize()
    plant.set_name("bplir_plant")
    return (plant, sg) if scene_graph else plant


def make_plant(p: PlantParams):
    """A stand-alone finalized plant (for closed-form checks and tools)."""
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(0.0)
    _populate(plant, p, None)
    plant.Finalize()
    return plant


def _link_inertia(m, lc, I, oc=0.0):
    from pydrake.multibody.tree import RotationalInertia, SpatialInertia

    # a slender link along -y: inertia I about x and z, small about y
    Irot = RotationalInertia(I, 1e-4 * I, I)
    return SpatialInertia.MakeFromCentralInertia(m, [oc, -lc, 0.0], Irot)


#: the plant fields a context can change (the links' inertial parameters);
#: lengths and gravity are fixed when the plant is built
INERTIAL_FIELDS = ("m1", "m2", "lc1", "lc2", "oc1", "oc2", "I1", "I2")


def set_inertial_parameters(plant, context, p: PlantParams) -> None:
    """Set both links' mass, centre of mass and inertia of ``p``
    (:data:`INERTIAL_FIELDS`) in the plant's parameters in ``context`` (the
    root context of a diagram holding ``plant``): the simulated robot of
    another Monte Carlo sample without rebuilding the diagram."""
    own = plant.GetMyMutableContextFromRoot(context)
    for name, (m, lc, inertia, oc) in (("link1", (p.m1, p.lc1, p.I1, p.oc1)),
                                       ("link2", (p.m2, p.lc2, p.I2, p.oc2))):
        plant.GetBodyByName(name).SetSpatialInertiaInBodyFrame(
            own, _link_inertia(m, lc, inertia, oc))


def _populate(plant, p: PlantParams, scene_graph) -> None:
    from pydrake.multibody.tree import RevoluteJoint

    plant.mutable_gravity_field().set_gravity_vector([0.0, -p.g, 0.0])
    link1 = plant.AddRigidBody("link1", _link_inertia(p.m1, p.lc1, p.I1, p.oc1))
    link2 = plant.AddRigidBody("link2", _link_inertia(p.m2, p.lc2, p.I2, p.oc2))
    world = plant.world_frame()
    j1 = plant.AddJoint(RevoluteJoint("gripper_joint", world, link1.body_frame(),
                                      [0.0, 0.0, 1.0], damping=0.0))
    elbow_frame = plant.AddFrame(_fixed_frame("elbow", link1, [0.0, -p.l1, 0.0]))
    j2 = plant.AddJoint(RevoluteJoint("elbow_joint", elbow_frame, link2.body_frame(),
                                      [0.0, 0.0, 1.0], damping=0.0))
    plant.AddJointActuator("elbow_motor", j2, effort_limit=math.inf)
    # gripper frame at the free end of link 2
    plant.AddFrame(_fixed_frame("free_gripper", link2, [0.0, -p.l2, 0.0]))
    for j in (j1, j2):
        j.set_position_limits([-math.inf], [math.inf])
    if scene_graph is not None:
        _register_geometry(plant, scene_graph, p, link1, link2)


def _fixed_frame(name, body, offset):
    from pydrake.math import RigidTransform
    from pydrake.multibody.tree import FixedOffsetFrame

    return FixedOffsetFrame(name, body.body_frame(), RigidTransform(offset))


def _register_geometry(plant, scene_graph, p, link1, link2) -> None:
    from pydrake.geometry import Box, Cylinder, Sphere
    from pydrake.math import RigidTransform

    blue = np.array([0.15, 0.35, 0.8, 1.0])
    orange = np.array([0.9, 0.45, 0.1, 1.0])
    for link, length, color in ((link1, p.l1, blue), (link2, p.l2, orange)):
        plant.RegisterVisualGeometry(
            link, RigidTransform([0.0, -length / 2, 0.0]), Box(0.04, length, 0.04),
            f"{link.name()}_box", color)
        plant.RegisterVisualGeometry(
            link, RigidTransform([0.0, -length, 0.0]), Sphere(0.05),
            f"{link.name()}_tip", color)
    plant.RegisterVisualGeometry(
        plant.world_body(), RigidTransform([0.0, 0.0, 0.0]), Cylinder(0.01, 0.01),
        "pivot", np.array([0.2, 0.2, 0.2, 1.0]))


def drake_manipulator_terms(plant, context, q, v):
    """(M, C v, g) from a Drake plant at (q, v), in the closed-form convention."""
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    M = plant.CalcMassMatrix(context)
    Cv = plant.CalcBiasTerm(context)
    g = -plant.CalcGravityGeneralizedForces(context)
    return M, Cv, g


def description_residual(description, samples: int = 50, seed: int = 0) -> float:
    """For a :class:`~bplir_drake.params.robot_file.RobotDescription`: the
    largest difference between the parsed plant's mass matrix, bias
    and gravity terms and the closed form of the extracted parameters at
    ``samples`` random states (mapped to the file's joint coordinates),
    relative to the largest term."""
    plant = parse_description(Path(description.path))
    context = plant.CreateDefaultContext()
    p, s = description.plant, np.diag([1.0, description.sign2])
    rng = np.random.default_rng(seed)
    worst, scale = 0.0, 0.0
    for _ in range(samples):
        x = np.concatenate([rng.uniform(-math.pi, math.pi, 2), rng.uniform(-8, 8, 2)])
        xf = description.to_file_state(x)
        plant.SetPositionsAndVelocities(context, xf)
        terms = ((plant.CalcMassMatrix(context), s @ mass_matrix(x[:2], p) @ s),
                 (plant.CalcBiasTerm(context), s @ bias_term(x[:2], x[2:], p)),
                 (-plant.CalcGravityGeneralizedForces(context), s @ gravity_vector(x[:2], p)))
        for theirs, ours in terms:
            worst = max(worst, float(np.abs(np.asarray(theirs) - ours).max()))
            scale = max(scale, float(np.abs(ours).max()))
    return worst / scale
