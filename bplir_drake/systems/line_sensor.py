"""The jaw's line range sensor, sampled with the IMUs.

The free gripper's distance below the line -- the *gap*, positive below --
with the fixed gripper at the origin and the line through it inclined by
``alpha`` (rad, rising along +x):

    gap = l1 cos(theta1 - alpha) + l2 cos(theta2 - alpha)

in the absolute link angles ``theta1 = q1``, ``theta2 = q1 + q2`` from the
downward vertical (zero at the start pose, where both grippers hold the
line).  :func:`line_gap` gives it and its gradient; the simulated sensor
(:class:`LineSensor`) evaluates it with the true link lengths, the
estimator (:func:`bplir_drake.systems.ekf.ekf_gap_update`) with the
nominal ones -- so a fused reading pulls the estimate to where the nominal
kinematics put the gripper at the measured gap, which is what the terminal
laws aim with.

A reading is valid while the true gap lies within ``[-range, range]``;
sample ``k``'s noise comes from ``numpy.random.default_rng((seed, k, 1))``
(the IMUs draw theirs per block of ticks,
:func:`~bplir_drake.systems.imu.noise_block`).  Before the swing the free gripper holds
the line, where the true gap is 0: the standstill calibration measures the
sensor's offset there (:func:`standstill_readings`).
"""
from __future__ import annotations

import math

import numpy as np
from pydrake.common.value import AbstractValue

from .pysystem import PySystem
from ..params import LineSensorParams
from .schedule import declare_sample
from .state import RobotState


def line_gap(theta1: float, theta2: float, l1: float, l2: float, alpha: float):
    """(gap, d gap / d theta1, d gap / d theta2) of the free gripper below
    the line (m), for absolute link angles (rad) and link lengths (m)."""
    c1, c2 = math.cos(theta1 - alpha), math.cos(theta2 - alpha)
    return (l1 * c1 + l2 * c2, -l1 * math.sin(theta1 - alpha),
            -l2 * math.sin(theta2 - alpha))


def standstill_readings(params: LineSensorParams, seed: int, n: int) -> np.ndarray:
    """``n`` readings of the free gripper's sensor while that gripper holds
    the line before a swing (the true gap is 0 there): its offset plus
    noise (``numpy.random.default_rng((seed, 2))``).  Their mean is the
    offset the standstill calibration removes
    (:attr:`~bplir_drake.systems.standstill.ImuCalibration.line_offset`)."""
    noise = np.random.default_rng((int(seed), 2)).standard_normal(int(n))
    return params.offset + params.sigma * noise


class LineSensor(PySystem):
    """Input ``state`` (the plant's, relative angles ``q1, q2, q1', q2'``);
    output ``line_gap`` (2): the held reading (m) and 1 where it is valid
    (0 out of range).  Sample ``k`` at ``t_k = k T``
    (:func:`~bplir_drake.systems.schedule.declare_sample`), like the IMUs.
    Output ``line_gap_now``: the sample the sensor takes at this instant
    (at ``t_k`` before its update, sample ``k``: what a system reads
    that takes its own samples at the tick's event).
    ``l1``, ``l2`` are the simulated robot's true link lengths and
    ``alpha`` the line's incline (rad)."""

    def __init__(self, params: LineSensorParams, l1: float, l2: float, alpha: float,
                 period: float, seed: int = 0):
        super().__init__()
        if not params.fitted:
            raise ValueError("line_sensor.fitted is false: there is no sensor to simulate")
        self.params = params
        self.geometry = (float(l1), float(l2), float(alpha))
        self.state_port = self.DeclareVectorInputPort("state", 4)
        self._sensor = self.DeclareAbstractParameter(AbstractValue.Make((params, int(seed))))
        # (reading, valid, sample index)
        self._held = self.DeclareDiscreteState(3)
        declare_sample(self, period, self._sample)
        self.DeclareVectorOutputPort("line_gap", 2, self._output, {self.xd_ticket()})
        self.DeclareVectorOutputPort("line_gap_now", 2,
                                     lambda c, o: o.SetFromVector(self._taken(c)[:2]),
                                     {self.xd_ticket(), self.state_port.ticket(),
                                      self.all_parameters_ticket()})

    def set_sensor(self, context, params: LineSensorParams, seed: int) -> None:
        """The noise, offset and noise seed of the sensor in ``context`` (the
        root context); the range is the built one."""
        if params.range != self.params.range:
            raise ValueError(f"line_sensor.range = {params.range:g} differs from the built "
                             f"sensor's {self.params.range:g} m")
        own = self.GetMyMutableContextFromRoot(context)
        own.get_mutable_abstract_parameter(self._sensor).set_value((params, int(seed)))

    def _sample(self, context, discrete_state):
        discrete_state.get_mutable_vector(self._held).SetFromVector(self._taken(context))

    def _taken(self, context):
        """(reading, valid, index + 1): the sample taken now."""
        p, seed = context.get_abstract_parameter(self._sensor).get_value()
        k = int(context.get_discrete_state(self._held).get_value()[2] + 0.5)   # a count
        q = RobotState(self.state_port.Eval(context))
        l1, l2, alpha = self.geometry
        gap = line_gap(q.q1, q.q1 + q.q2, l1, l2, alpha)[0]
        valid = abs(gap) <= p.range
        noise = p.sigma * np.random.default_rng((seed, k, 1)).standard_normal() if valid else 0.0
        reading = gap + p.offset + noise if valid else 0.0
        return [reading, 1.0 if valid else 0.0, k + 1]

    def _output(self, context, out):
        out.SetFromVector(context.get_discrete_state(self._held).get_value()[:2])
