"""A trained policy as a controller plug-in: the learning environment's
action computed on the robot's computer from what the controller reads."""
from __future__ import annotations

import numpy as np

from .action import share_torque
from .pysystem import PySystem


class PolicyTorque(PySystem):
    """A controller plug-in from a policy: inputs ``state`` (4, the
    estimate) and, with ``observation = "imu"``, ``imu`` (6, the IMU sample);
    output ``torque`` = :func:`share_torque` of ``policy(observation)``, the
    observation being that input's value (float64), as the learning
    environment gives it."""

    def __init__(self, policy, torque_limit: float, observation: str = "estimate"):
        super().__init__()
        if observation not in ("estimate", "imu"):
            raise ValueError(f"observation = {observation!r}; allowed: estimate, imu")
        self.policy, self.torque_limit = policy, float(torque_limit)
        state = self.DeclareVectorInputPort("state", 4)
        self.source = self.DeclareVectorInputPort("imu", 6) if observation == "imu" else state
        self.DeclareVectorOutputPort("torque", 1, self._torque, {self.source.ticket()})

    def _torque(self, context, out):
        obs = np.array(self.source.Eval(context), dtype=np.float64)
        out.SetAtIndex(0, share_torque(self.policy(obs), self.torque_limit))
