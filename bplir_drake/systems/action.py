"""The elbow command given as a share of the torque limit: a learning
environment's action in the controller's place.

:class:`ActionTorque` has the controller plug-in's ports (input ``state``,
which it does not read, output ``torque``) and an ``action`` input, the
command as a share of ``torque_limit`` in [-1, 1] (clipped there); the
swing diagram exports that input as its own ``action`` port
(:func:`~bplir_drake.diagrams.build_swing`'s ``action_input``).
:class:`~bplir_drake.systems.policy_torque.PolicyTorque` is the same law
with the share computed by a policy."""
from __future__ import annotations

import numpy as np

from .pysystem import PySystem


def share_torque(share, torque_limit: float) -> float:
    """The elbow command (N m) of the share ``share`` (clipped to [-1, 1])
    of ``torque_limit``."""
    return float(torque_limit) * min(1.0, max(-1.0, float(np.asarray(share).reshape(-1)[0])))


class ActionTorque(PySystem):
    """Inputs ``state`` (4, unread) and ``action`` (1: a share of
    ``torque_limit``); output ``torque`` (N m), :func:`share_torque`."""

    def __init__(self, torque_limit: float):
        super().__init__()
        self.torque_limit = float(torque_limit)
        self.DeclareVectorInputPort("state", 4)
        self.action_port = self.DeclareVectorInputPort("action", 1)
        self.DeclareVectorOutputPort("torque", 1, self._torque,
                                     {self.action_port.ticket()})

    def _torque(self, context, out):
        out.SetAtIndex(0, share_torque(self.action_port.Eval(context), self.torque_limit))
