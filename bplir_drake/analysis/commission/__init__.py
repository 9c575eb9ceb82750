"""Commissioning a robot from its description: plans and gains solved from
similar robots' plans, a verification study scaled to the robot, and a
verdict naming the physical limits (:func:`commission`)."""
from .commission_result import CommissionResult
from .commissioning import commission, default_spacings
from .verdict import READY_RATE

__all__ = ["CommissionResult", "READY_RATE", "commission", "default_spacings"]
