"""The acrobot with its joint friction in closed form as a Drake
``SymbolicVectorSystem``: the same dynamics as
:func:`~bplir_drake.systems.frictional_plant.frictional_plant` (the
``MultibodyPlant`` and its friction system), evaluated in C++ at every
scalar type, so that trajectory optimisation and the tracking LQR, which
evaluate the dynamics and their derivatives thousands of times, do not call
Python for each evaluation."""
from __future__ import annotations

import numpy as np

from ..params import FrictionParams, PlantParams
from .friction import friction_torques
from .plant import forward_dynamics


def symbolic_plant(plant: PlantParams, friction: FrictionParams):
    """A ``SymbolicVectorSystem`` of ``plant`` (4.5)-(4.8) with the smoothed
    friction (4.11) of ``friction``: state (q1, q2, q1d, q2d), input the
    elbow torque (N m), output the state."""
    from pydrake.symbolic import MakeVectorVariable
    from pydrake.systems.primitives import SymbolicVectorSystem

    x, u = MakeVectorVariable(4, "x"), MakeVectorVariable(1, "u")
    # object arrays of expressions: numpy would report floating-point flags
    # left by earlier arithmetic as if these symbolic operations raised them
    with np.errstate(invalid="ignore"):
        qdd = forward_dynamics(x[:2], x[2:], u[0], friction_torques(x[2:], friction), plant)
    system = SymbolicVectorSystem(state=x, input=u, dynamics=np.r_[x[2:], qdd], output=x)
    system.set_name("plant_with_friction_closed_form")
    return system
