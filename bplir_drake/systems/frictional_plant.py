"""The acrobot with its joint friction as one system: the model that
trajectory optimisation plans on and that linearisation differentiates."""
from __future__ import annotations

from ..params import FrictionParams, PlantParams
from .friction import JointFriction
from .plant import add_acrobot_plant


def frictional_plant(plant: PlantParams, friction: FrictionParams):
    """A Drake ``Diagram`` of the ``MultibodyPlant`` of ``plant`` and the
    templated :class:`~bplir_drake.systems.friction.JointFriction` of
    ``friction`` on its applied-force port: input ``elbow_torque`` (N m),
    output ``state`` (q1, q2, q1d, q2d).  It has no state but the plant's
    and converts to AutoDiffXd (``Linearize``, ``DirectCollocation``); its
    subsystems are named ``bplir_plant`` and ``joint_friction``."""
    from pydrake.systems.framework import DiagramBuilder

    builder = DiagramBuilder()
    mbp = add_acrobot_plant(builder, plant)
    law = builder.AddSystem(JointFriction(friction))
    law.set_name("joint_friction")
    builder.Connect(mbp.get_state_output_port(), law.get_input_port(0))
    builder.Connect(law.get_output_port(0), mbp.get_applied_generalized_force_input_port())
    builder.ExportInput(mbp.get_actuation_input_port(), "elbow_torque")
    builder.ExportOutput(mbp.get_state_output_port(), "state")
    diagram = builder.Build()
    diagram.set_name("plant_with_friction")
    return diagram
