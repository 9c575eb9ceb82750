"""Gripper interlock: the fixed gripper may only open once the free gripper
holds the line.

A small state machine updated every ``period`` (2 ms by default) from the
*true* plant state -- in the robot this is the gripper's contact/proximity
sensing, not the estimator.  Outcomes (SPEC.md, "Swing scenarios and
success"):

* ``captured``: first arrival -- after the vertical has been passed, the free
  gripper comes within ``capture_distance`` of the line (or crosses it
  between two updates) at least ``min_travel_fraction * D`` along the line
  from where it started -- at a speed ``<= capture_speed``;
* ``crash``: that first arrival is faster;
* ``timeout``: no arrival within ``max_time``;
* ``fault``: the driver's i^2 t interlock tripped (torque limit held longer
  than the driver allows), or the estimate or the applied torque became
  non-finite, before the arrival.

Only ``captured`` sets ``fixed_gripper_open``; the simulation is ended by the
simulator monitor (:func:`bplir_drake.simulate.run_until_outcome`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydrake.systems.framework import LeafSystem

from ..params import ScenarioParams
from .plant import gripper_position, gripper_velocity

OUTCOMES = ("swinging", "captured", "crash", "timeout", "fault")


@dataclass(frozen=True)
class LineGeometry:
    l1: float
    l2: float
    alpha: float
    grip_spacing: float


def line_metrics(x, g: LineGeometry):
    """(distance to the line, signed; along-line position; travel from the
    start; gripper speed) of the free gripper at state ``x``."""
    p = gripper_position(x[:2], g.l1, g.l2)
    v = gripper_velocity(x[:2], x[2:4], g.l1, g.l2)
    ca, sa = math.cos(g.alpha), math.sin(g.alpha)
    along = p[0] * ca + p[1] * sa
    normal = -p[0] * sa + p[1] * ca
    return normal, along, along + g.grip_spacing, float(math.hypot(v[0], v[1]))


class GripperInterlock(LeafSystem):
    """Inputs ``state`` (true plant state), ``tripped`` (driver interlock),
    ``estimate`` (the filter's relative state) and ``torque`` (applied).
    Output ``status`` = [mode index, fixed gripper open, event time, speed at
    arrival, distance at arrival, travel at arrival, closest distance]."""

    N = 7

    def __init__(self, geometry: LineGeometry, scenario: ScenarioParams, period: float = 0.002):
        super().__init__()
        self.geometry, self.scenario, self.period = geometry, scenario, period
        self.DeclareVectorInputPort("state", 4)
        self.DeclareVectorInputPort("tripped", 1)
        self.DeclareVectorInputPort("estimate", 4)
        self.DeclareVectorInputPort("torque", 1)
        # [mode, fixed_open, t_event, speed, distance, travel, min_dist, passed, last_normal]
        self._xd = self.DeclareDiscreteState(np.array([0, 0, math.nan, math.nan, math.nan,
                                                       math.nan, math.inf, 0, -math.inf]))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)
        self.DeclareVectorOutputPort("status", self.N, self._out, {self.xd_ticket()})

    def _update(self, context, discrete_state):
        d = context.get_discrete_state(self._xd).get_value().copy()
        if d[0] != 0:
            return
        t = context.get_time()
        sc, g = self.scenario, self.geometry
        x = self.get_input_port(0).Eval(context)
        normal, along, travel, speed = line_metrics(x, g)
        passed = d[7] > 0.5 or (x[0] - g.alpha) > 0.0
        d[7] = 1.0 if passed else 0.0
        if passed and travel > 0.0:
            d[6] = min(d[6], abs(normal))
        est = self.get_input_port(2).Eval(context)
        tau = self.get_input_port(3).Eval(context)[0]
        crossed = d[8] < 0.0 <= normal
        if passed and travel >= sc.min_travel_fraction * sc.grip_spacing and (
                abs(normal) <= sc.capture_distance or crossed):
            ok = speed <= sc.capture_speed
            d[0] = OUTCOMES.index("captured" if ok else "crash")
            d[1] = 1.0 if ok else 0.0
            d[2:6] = [t, speed, abs(normal), travel]
        elif self.get_input_port(1).Eval(context)[0] > 0.5 or not (
                np.all(np.isfinite(est)) and math.isfinite(tau)):
            d[0] = OUTCOMES.index("fault")
            d[2] = t
        elif t >= sc.max_time:
            d[0] = OUTCOMES.index("timeout")
            d[2] = t
        d[8] = normal
        discrete_state.get_mutable_vector(self._xd).SetFromVector(d)

    def _out(self, context, out):
        out.SetFromVector(context.get_discrete_state(self._xd).get_value()[:self.N])

    def outcome(self, context) -> str:
        return OUTCOMES[int(self.GetMyContextFromRoot(context).get_discrete_state(self._xd)
                            .get_value()[0])]

    def status(self, context) -> dict:
        d = self.GetMyContextFromRoot(context).get_discrete_state(self._xd).get_value()
        return {"outcome": OUTCOMES[int(d[0])], "fixed_gripper_open": bool(d[1] > 0.5),
                "event_time_s": float(d[2]), "capture_speed_mps": float(d[3]),
                "capture_distance_m": float(d[4]), "travel_m": float(d[5]),
                "closest_distance_m": float(d[6])}
