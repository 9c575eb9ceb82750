"""Joint friction (4.10)/(4.11) as a scalar-templated Drake system.

``ForceElement`` cannot be subclassed from Python, so friction is a
``LeafSystem_[T]`` that reads the plant state and writes the generalized
force ``-f(qd)`` into the plant's applied-generalized-force port.  The state
output has no direct feedthrough, so there is no algebraic loop, and because
the system is templated (double, AutoDiffXd, Expression) a diagram
containing it still linearises with ``Linearize``.
"""
from __future__ import annotations

import math
import sys

import numpy as np
import pydrake.math as dmath
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem

from .pysystem import quick_template_scopes, weak_callback
from .state import Q1D, Q2D
from ..params import FrictionParams


def joint_friction(qd, fv: float, fc: float, b: float, k_drag: float = 0.0):
    """Candidate function (4.11) for one joint; drag opposes motion.

    ``f = fv*qd + fc*(2/pi)*atan(qd/b) + k_drag*qd*|qd|`` with
    ``k_drag = 0.5*rho*Cd*A``.  Works for floats, numpy arrays, AutoDiffXd and
    Expression.
    """
    if isinstance(qd, np.ndarray) and qd.dtype != object:
        return fv * qd + fc * (2.0 / math.pi) * np.arctan(qd / b) + k_drag * qd * np.abs(qd)
    if isinstance(qd, (float, np.floating)):  # fast path for plain numbers
        return fv * qd + fc * (2.0 / math.pi) * math.atan(qd / b) + k_drag * qd * abs(qd)
    return fv * qd + fc * (2.0 / math.pi) * dmath.atan(qd / b) + k_drag * qd * abs(qd)


def joint_friction_discontinuous(qd, fv: float, fc: float, k_drag: float = 0.0):
    """Reference model (4.10): ``fc*sgn(qd) + fv*qd + drag`` (drag opposes motion)."""
    qd = np.asarray(qd, dtype=float)
    return fc * np.sign(qd) + fv * qd + k_drag * qd * np.abs(qd)


def friction_torques(qd, p: FrictionParams):
    """(f1, f2) of (4.11) for both joints (zero when friction is disabled)."""
    if not p.enabled:
        return np.array([0.0 * qd[0], 0.0 * qd[1]])
    k1, k2 = p.drag_coefficients()
    return np.array([joint_friction(qd[0], p.fv1, p.fc1, p.b, k1),
                     joint_friction(qd[1], p.fv2, p.fc2, p.b, k2)])


def friction_torques_along(states, p: FrictionParams) -> np.ndarray:
    """:func:`friction_torques` at each row's joint rates (columns 2 and 3
    of ``states``, shape (N, 4)): an (N, 2) array, row by row the same
    numbers (the scalar law, not numpy's vectorised arctan, which differs
    in the last bit)."""
    if not p.enabled:
        return 0.0 * np.asarray(states, dtype=float)[:, 2:4]
    k1, k2 = p.drag_coefficients()
    return np.array([(joint_friction(v1, p.fv1, p.fc1, p.b, k1),
                      joint_friction(v2, p.fv2, p.fc2, p.b, k2))
                     for v1, v2 in np.asarray(states, dtype=float)[:, 2:4].tolist()],
                    dtype=float).reshape(-1, 2)


@TemplateSystem.define("JointFriction_", scope=sys.modules[__name__])
def JointFriction_(T):
    """Joint friction as a scalar-templated system (double, AutoDiffXd, Expression), for
    ``Linearize`` and the planner."""
    class Impl(LeafSystem_[T]):
        """Input ``state`` (q1, q2, q1d, q2d); output ``generalized_force`` = -f(qd)."""

        def _construct(self, params: FrictionParams, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self.params = params
            self.DeclareVectorInputPort("state", 4)
            self.DeclareVectorOutputPort("generalized_force", 2, weak_callback(self, self._calc),
                                         {self.all_input_ports_ticket()})

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other.params, converter=converter)

        def _calc(self, context, output):
            x = self.get_input_port(0).Eval(context)
            f = friction_torques(x[Q1D:Q2D + 1], self.params)
            output.SetFromVector(np.array([-f[0], -f[1]]))

    return Impl


with quick_template_scopes():
    JointFriction = JointFriction_[None]


#: the coefficients a context carries in :func:`friction_system`, in this
#: order; the Coulomb smoothing ``b`` and the drag are fixed when it is built
FRICTION_PARAMETERS = ("fv1", "fv2", "fc1", "fc2")


def friction_parameter_vector(p: FrictionParams) -> np.ndarray:
    """:data:`FRICTION_PARAMETERS` of ``p`` (zero when friction is disabled)."""
    if not p.enabled:
        return np.zeros(len(FRICTION_PARAMETERS))
    return np.array([p.fv1, p.fv2, p.fc1, p.fc2])


def friction_structure(p: FrictionParams) -> tuple:
    """What :func:`friction_system` fixes when it is built: the Coulomb
    smoothing ``b`` (rad/s) and the drag coefficients (zero when disabled)."""
    return (p.b, *(p.drag_coefficients() if p.enabled else (0.0, 0.0)))


def friction_system(params: FrictionParams, *, in_context: bool = False):
    """Joint friction as C++ systems for simulation: the same law
    (:func:`joint_friction`, evaluated on symbolic variables) in a
    ``SymbolicVectorSystem``, so no Python runs while the integrator steps.

    Input ``state`` (q1, q2, q1d, q2d); output ``generalized_force``
    ``-f(qd)`` (2).  Its one continuous state is the energy friction has
    dissipated, ``W' = f1 q1d + f2 q2d`` (J): Drake 1.51's
    ``SymbolicVectorSystem`` cannot be stateless inside a continuous
    diagram, and the dissipated energy is worth having.

    By default the coefficients are constants of the law (the fastest
    form).  With ``in_context=True`` the coefficients
    (:data:`FRICTION_PARAMETERS`, default from ``params``) are the value of a
    ``ConstantVectorSource`` inside a small diagram, a numeric parameter of
    the context, so a context can carry other friction (:func:`set_friction`)
    without rebuilding; ``b`` and the drag stay constants
    (:func:`friction_structure`).  That form costs about 7 % of a swing's
    time (the coefficients are read from the context at every derivative).
    For ``Linearize`` use :class:`JointFriction` (templated, no extra
    state)."""
    from pydrake.symbolic import MakeVectorVariable, Variable
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource, Multiplexer, SymbolicVectorSystem

    x = MakeVectorVariable(4, "x")
    work = Variable("dissipated")
    if not in_context:
        f = friction_torques(x[Q1D:Q2D + 1], params)
        return SymbolicVectorSystem(state=[work], input=x, dynamics=[f[0] * x[Q1D] + f[1] * x[Q2D]],
                                    output=[-f[0], -f[1]])
    c = [Variable(name) for name in FRICTION_PARAMETERS]
    b, *drag = friction_structure(params)
    f = [joint_friction(x[Q1D + i], c[i], c[2 + i], b, drag[i]) for i in range(2)]
    law = SymbolicVectorSystem(state=[work], input=[*x, *c],
                               dynamics=[f[0] * x[Q1D] + f[1] * x[Q2D]], output=[-f[0], -f[1]])
    builder = DiagramBuilder()
    law = builder.AddNamedSystem("law", law)
    coeffs = builder.AddNamedSystem("coefficients",
                                    ConstantVectorSource(friction_parameter_vector(params)))
    mux = builder.AddNamedSystem("mux", Multiplexer([4, len(FRICTION_PARAMETERS)]))
    builder.ExportInput(mux.get_input_port(0), "state")
    builder.Connect(coeffs.get_output_port(0), mux.get_input_port(1))
    builder.Connect(mux.get_output_port(0), law.get_input_port(0))
    builder.ExportOutput(law.get_output_port(0), "generalized_force")
    return builder.Build()


def set_friction(system, context, p: FrictionParams) -> None:
    """Set the coefficients of ``system`` (a :func:`friction_system` built
    ``in_context``) in ``context`` (the root context of a diagram holding
    it); ``p`` must have the built :func:`friction_structure`."""
    src = system.GetSubsystemByName("coefficients")
    src.get_mutable_source_value(src.GetMyMutableContextFromRoot(context)).SetFromVector(
        friction_parameter_vector(p))
