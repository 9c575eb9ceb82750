"""A Gymnasium environment for learning brachiation controllers (the
``gym`` extra: ``pip install "bplir-drake[gym]"``).

:class:`BrachiationEnv` is one swing of the package's swing diagram with
the elbow command as the action (registered as ``"bplir/Brachiation-v0"``);
:func:`as_controller` turns a policy trained on it into a controller
plug-in that ``bplir swing``, ``montecarlo`` and ``benchmark`` run."""
from __future__ import annotations

import gymnasium as gym

from ..diagrams.parts import torque_limit
from ..systems.policy_torque import PolicyTorque
from .env import OBSERVATIONS, TERMINAL_REWARD, BrachiationEnv

ENV_ID = "bplir/Brachiation-v0"


def as_controller(policy, observation: str = "estimate"):
    """A controller plug-in factory (``factory(params) -> System``) that
    commands ``policy(observation)`` as a share of the robot's torque
    limit, with the observation the environment gives (``"estimate"`` or
    ``"imu"``): in a plug-in file, ``make = as_controller(my_policy)`` and
    ``bplir benchmark --controllers file.py:make``."""
    if observation not in OBSERVATIONS:
        raise ValueError(f"observation = {observation!r}; allowed: " + ", ".join(OBSERVATIONS))

    def make(params):
        return PolicyTorque(policy, torque_limit(params), observation)

    return make


if ENV_ID not in gym.registry:
    gym.register(ENV_ID, entry_point="bplir_drake.gym.env:BrachiationEnv")

__all__ = ["BrachiationEnv", "as_controller", "ENV_ID", "OBSERVATIONS", "TERMINAL_REWARD"]
