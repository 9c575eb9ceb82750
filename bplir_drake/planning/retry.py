"""A try again from hanging kept cool: the one manoeuvre whose numbers
depend on a plan (:func:`retry`)."""
from __future__ import annotations

import math
from dataclasses import replace

from ..params import BplirParams, Manoeuvre, ParameterError, derive, planned_from_hanging
from .solve import i2t_allowance, planned_i2t, scenario_plan


def retry(robot: BplirParams, manoeuvre: Manoeuvre, hardware=()) -> BplirParams:
    """``derive(robot, manoeuvre, hardware)`` for a try again from hanging
    (``manoeuvre.context = "retry"``); where its plan ends at the line and
    would by itself use more of the driver's i^2 t budget than
    ``hanging.i2t_share`` allows (a hot pump ends at the torque limit and
    crashes), the try whose plan keeps the traversal's end depth
    (``end_at_line`` false)."""
    m = replace(manoeuvre, context="retry")
    p = derive(robot, m, hardware)
    if m.end_at_line is None and p.plan.end_depth == 0.0 and too_hot(p):
        p = derive(robot, replace(m, end_at_line=False), hardware)
    return p


def too_hot(p: BplirParams) -> bool:
    """Whether the plan from hanging of ``p`` by itself uses more of the
    driver's i^2 t than :func:`~.solve.i2t_allowance` (never with
    ``hanging.i2t_share`` "none", or without a plan)."""
    made = planned_from_hanging(p)
    allowance = i2t_allowance(made)
    if math.isinf(allowance):
        return False
    try:
        plan = scenario_plan(p.resolved())
    except ParameterError:
        return False
    return planned_i2t(plan, made.motor) > allowance
