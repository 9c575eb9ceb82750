"""The manoeuvres the tests derive often, as ``params.derive`` gives them."""
import math

from bplir_drake.planning.retry import retry
from bplir_drake.params import Manoeuvre, derive


def step(gripper: int, spacing: float, incline: float, **kw) -> Manoeuvre:
    """A traversal's swing holding with ``gripper`` on a chord of ``spacing``
    (m) inclined by ``incline`` (rad)."""
    return Manoeuvre(gripper=gripper, spacing=spacing, incline_deg=math.degrees(incline),
                     context="traverse", **kw)


def traverse_swing(robot, gripper: int, spacing: float, incline: float, **kw):
    """The parameters of that traversal swing of ``robot``."""
    return derive(robot, step(gripper, spacing, incline, **kw))


def tried(robot, gripper: int, spacing: float, incline: float, **kw):
    """That swing tried again from hanging (kept cool)."""
    return retry(robot, step(gripper, spacing, incline, **kw))
