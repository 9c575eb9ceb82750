"""A user's own state estimator, plugged into the swing diagram.

    bplir swing --estimator examples/my_estimator.py:make
    bplir benchmark --quick --controllers qft --estimator examples/my_estimator.py:make

The gyro integral (5.41): each link's absolute angle integrated from its
gyro, starting at the known pose on the line; rates read straight from the
gyros.  No accelerometers, so no correction of gyro bias or drift.  The port
contract (bplir_drake/diagrams/plugin.py): input ``imu`` (gyro1, gyro2,
acc1_x, acc1_y, acc2_x, acc2_y), output ``state`` (q1, q2, q1d, q2d); the
factory gets the nominal model only.
"""
import numpy as np
from pydrake.systems.framework import LeafSystem

from bplir_drake.diagrams import swing_geometry


class GyroIntegral(LeafSystem):
    def __init__(self, params):
        super().__init__()
        q0 = swing_geometry(params)[0]                 # start pose on the line (rad)
        self.T = params.controller.period              # one IMU sample per tick
        self.imu = self.DeclareVectorInputPort("imu", 6)
        theta0 = [q0[0], q0[0] + q0[1]]                # absolute link angles
        self.theta = self.DeclareDiscreteState(np.array(theta0))
        self.DeclarePeriodicDiscreteUpdateEvent(self.T, 0.0, self.integrate)
        self.DeclareVectorOutputPort("state", 4, self.output)

    def integrate(self, context, state):
        # at t_k the input still holds sample k-1: theta(t_k) = theta(t_k-1) + T w_k-1
        gyro = self.imu.Eval(context)[:2]
        theta = context.get_discrete_state(self.theta).get_value()
        state.get_mutable_vector(self.theta).set_value(theta + self.T * gyro)

    def output(self, context, out):
        t1, t2 = context.get_discrete_state(self.theta).get_value()
        w1, w2 = self.imu.Eval(context)[:2]             # sample k
        out.SetFromVector([t1, t2 - t1, w1, w2 - w1])   # relative elbow angle and rate


def make(params):
    """The factory ``--estimator examples/my_estimator.py:make`` calls."""
    return GyroIntegral(params)
