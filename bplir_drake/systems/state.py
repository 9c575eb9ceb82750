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

#: the same orders as integers, for compiled code (numba reads no view):
#: positions in a ``RobotState`` vector ...
Q1, Q2, Q1D, Q2D = (RobotState._fields.index(n) for n in ("q1", "q2", "q1d", "q2d"))
#: ... and in an ``AbsoluteState`` vector
THETA1, THETA2, OMEGA1, OMEGA2 = (AbsoluteState._fields.index(n)
                                  for n in ("theta1", "theta2", "omega1", "omega2"))

#: the IMU readings the onboard computer takes in (its ``imu_readings``
#: input): each IMU's gyro, then each one's accelerometer, in the sensor
#: frame (rad/s, m/s^2); a link's rate is its gyro's z, the accelerometers'
#: x and y lie in the plane of the swing
ImuReadings = namedview("ImuReadings", [f"{kind}{i}_{axis}" for kind in ("gyro", "accel")
                                        for i in (1, 2) for axis in "xyz"])
GYRO1_Z, GYRO2_Z, ACCEL1_X, ACCEL1_Y, ACCEL2_X, ACCEL2_Y = (
    ImuReadings._fields.index(n)
    for n in ("gyro1_z", "gyro2_z", "accel1_x", "accel1_y", "accel2_x", "accel2_y"))
