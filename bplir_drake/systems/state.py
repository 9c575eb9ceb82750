"""Named views of the vectors the systems pass each other (Drake's
``namedview``: a view of the same numbers, read and written by name).

``RobotState`` is the robot's state in the package's conventions -- ``q1``
(rad, link 1 from the downward vertical, counter-clockwise), ``q2`` (rad,
link 2 relative to link 1), their rates ``q1d``, ``q2d`` (rad/s): the
plant's state output, the ``estimate`` the controllers read, the
``true_state`` and ``estimate`` outputs of the swing diagram.
``AbsoluteState`` is the kinematic EKF's: each link's absolute angle
``theta1``, ``theta2`` (rad, from the downward vertical) and rate
``omega1``, ``omega2`` (rad/s)."""
from __future__ import annotations

from pydrake.common.containers import namedview

RobotState = namedview("RobotState", ["q1", "q2", "q1d", "q2d"])
AbsoluteState = namedview("AbsoluteState", ["theta1", "theta2", "omega1", "omega2"])
