"""A user's own swing controller, plugged into the swing diagram.

    bplir swing --controller examples/my_controller.py:make
    bplir benchmark --quick --controllers qft,examples/my_controller.py:make

PD on the reverse-time-symmetric path q2 = q1 q2f / q1f (7.6), made linear
by the nominal CPFL (q2'' = v).  The port contract
(bplir_drake/diagrams/plugin.py): input ``state`` (q1, q2, q1d, q2d),
output ``torque`` (N m); the factory gets the nominal model only.
"""
import numpy as np
from pydrake.systems.framework import LeafSystem

from bplir_drake.diagrams import swing_geometry
from bplir_drake.systems.controller import cpfl_torque


class PathPD(LeafSystem):
    def __init__(self, params, kp: float = 120.0, kd: float = 22.0):
        super().__init__()
        _, target, _, _ = swing_geometry(params)      # where the swing ends (rad)
        self.k = target[1] / target[0]                # slope of the path q2(q1)
        self.kp, self.kd = kp, kd
        self.plant, self.limit = params.plant, params.controller.torque_limit
        self.state = self.DeclareVectorInputPort("state", 4)
        self.DeclareVectorOutputPort("torque", 1, self.command)

    def command(self, context, out):
        q1, q2, q1d, q2d = self.state.Eval(context)
        v = self.kp * (self.k * q1 - q2) + self.kd * (self.k * q1d - q2d)
        tau = cpfl_torque([q1, q2], [q1d, q2d], v, self.plant)
        out.SetAtIndex(0, float(np.clip(tau, -self.limit, self.limit)))


def make(params):
    """The factory ``--controller examples/my_controller.py:make`` calls."""
    return PathPD(params)
