"""The CPFL loop on the true state: the plant family the outer loop is
designed for (linearised), the closed loop tracking a reference, and the
step tests of the CPFL loop (4.7)."""
from __future__ import annotations

from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from ..params import BplirParams
from ..systems.controller import CpflController
from ..systems.motor import MotorDriver
from .parts import Built, add_plant_with_friction, sampled, torque_source
from dataclasses import replace


def build_cpfl_plant(params: BplirParams) -> Built:
    """Simulated plant + friction behind the *nominal* CPFL inner loop, with
    the outer-loop signal ``v`` as the diagram input and the plant state as
    output: linearising it from v to q2 gives the plant family the outer loop
    is designed for (4.7)."""

    builder = DiagramBuilder()
    plant, fr = add_plant_with_friction(builder, params.simulated_plant,
                                        params.simulated_friction, linearizable=True)
    ctrl = replace(params.controller, k_num=(0.0,), k_den=(1.0,), f_num=(1.0,), f_den=(1.0,),
                   aw_gain=0.0, sign_correct=False, torque_limit=1e9)
    c = builder.AddSystem(CpflController(params.plant, ctrl, params.friction, continuous=True))
    c.set_name("cpfl")
    builder.Connect(plant.get_state_output_port(), c.GetInputPort("state"))
    builder.Connect(builder.AddSystem(ConstantVectorSource([0.0])).get_output_port(0),
                    c.GetInputPort("reference"))
    builder.Connect(builder.AddSystem(ConstantVectorSource([1e9])).get_output_port(0),
                    c.GetInputPort("torque_available"))
    builder.ExportInput(c.GetInputPort("feedforward"), "v")
    builder.Connect(c.GetOutputPort("torque"), plant.get_actuation_input_port())
    builder.ExportOutput(plant.get_state_output_port(), "state")
    diagram = builder.Build()
    diagram.set_name("cpfl_plant")
    return Built(diagram, plant, {"friction": fr, "controller": c}, {}, params)


def build_control_loop(params: BplirParams, reference=0.0, *, continuous: bool = False,
                       motor: bool = False, torque_limit: float | None = None,
                       input_disturbance=None, log_period: float = 0.002) -> Built:
    """Closed loop on the true state: plant + friction + CPFL/outer loop
    (nominal parameters) tracking ``reference`` (float or (times, values)
    zero-order-hold schedule of q2_ref).  ``motor=True`` puts the motor and
    driver between controller and plant (and feeds its deliverable torque
    back for anti-windup); otherwise the controller's torque is applied
    directly.  ``input_disturbance`` is an elbow-torque schedule (times,
    values) added to the applied torque.
    ``continuous=True`` builds the continuous-time controller (the loop can
    then be linearised; with the reference exported as input ``reference``
    when ``reference`` is None)."""

    from pydrake.systems.primitives import Adder

    builder = DiagramBuilder()
    plant, fr = add_plant_with_friction(builder, params.simulated_plant,
                                        params.simulated_friction, linearizable=continuous)
    ctrl = params.controller if torque_limit is None else replace(params.controller,
                                                                  torque_limit=torque_limit)
    c = builder.AddSystem(CpflController(params.plant, ctrl, params.friction,
                                         continuous=continuous))
    c.set_name("controller")

    def held(port):  # the discrete controller reads its inputs at its ticks
        return port if continuous else sampled(builder, port, ctrl.period)

    builder.Connect(held(plant.get_state_output_port()), c.GetInputPort("state"))
    if reference is None:
        builder.ExportInput(c.GetInputPort("reference"), "reference")
    else:
        src = torque_source(builder, reference)
        src.set_name("reference")
        builder.Connect(held(src.get_output_port(0)), c.GetInputPort("reference"))
    builder.Connect(held(builder.AddSystem(ConstantVectorSource([0.0])).get_output_port(0)),
                    c.GetInputPort("feedforward"))
    torque = c.GetOutputPort("torque")
    systems = {"friction": fr, "controller": c}
    if motor:
        drv = builder.AddSystem(MotorDriver(replace(params.motor, torque_limit=ctrl.torque_limit)))
        drv.set_name("motor")
        builder.Connect(torque, drv.GetInputPort("torque_command"))
        builder.Connect(plant.get_state_output_port(), drv.GetInputPort("state"))
        builder.Connect(drv.GetOutputPort("available"), c.GetInputPort("torque_available"))
        torque = drv.GetOutputPort("torque")
        systems["motor"] = drv
    else:
        builder.Connect(held(builder.AddSystem(ConstantVectorSource([ctrl.torque_limit]))
                             .get_output_port(0)), c.GetInputPort("torque_available"))
    if input_disturbance is not None:
        dist = torque_source(builder, input_disturbance)
        add = builder.AddSystem(Adder(2, 1))
        builder.Connect(torque, add.get_input_port(0))
        builder.Connect(dist.get_output_port(0), add.get_input_port(1))
        torque = add.get_output_port(0)
    builder.Connect(torque, plant.get_actuation_input_port())
    builder.ExportOutput(plant.get_state_output_port(), "state")
    loggers = {"state": LogVectorOutput(plant.get_state_output_port(), builder, log_period),
               "torque": LogVectorOutput(torque, builder, log_period),
               "v": LogVectorOutput(c.GetOutputPort("v"), builder, log_period),
               "torque_unsaturated": LogVectorOutput(c.GetOutputPort("torque_unsaturated"),
                                                     builder, log_period)}
    diagram = builder.Build()
    diagram.set_name("control_loop")
    return Built(diagram, plant, systems, loggers, params)


def build_cpfl_step(params: BplirParams, v_schedule, log_period: float = 0.002) -> Built:
    """Step tests of the CPFL loop (4.7): simulated plant + friction + motor,
    the *discrete* nominal CPFL controller with no outer loop (K = 0, F = 1)
    and the outer-loop signal ``v`` from a schedule (times, values)."""

    builder = DiagramBuilder()
    plant, fr = add_plant_with_friction(builder, params.simulated_plant,
                                        params.simulated_friction)
    ctrl = replace(params.controller, k_num=(0.0,), k_den=(1.0,), f_num=(1.0,), f_den=(1.0,),
                   aw_gain=0.0, sign_correct=False)
    c = builder.AddSystem(CpflController(params.plant, ctrl, params.friction))
    motor = builder.AddSystem(MotorDriver(params.motor))
    T = params.controller.period
    builder.Connect(sampled(builder, plant.get_state_output_port(), T), c.GetInputPort("state"))
    builder.Connect(sampled(builder, builder.AddSystem(ConstantVectorSource([0.0]))
                            .get_output_port(0), T), c.GetInputPort("reference"))
    builder.Connect(sampled(builder, torque_source(builder, v_schedule).get_output_port(0), T),
                    c.GetInputPort("feedforward"))
    builder.Connect(motor.GetOutputPort("available"), c.GetInputPort("torque_available"))
    builder.Connect(c.GetOutputPort("torque"), motor.GetInputPort("torque_command"))
    builder.Connect(plant.get_state_output_port(), motor.GetInputPort("state"))
    builder.Connect(motor.GetOutputPort("torque"), plant.get_actuation_input_port())
    loggers = {"state": LogVectorOutput(plant.get_state_output_port(), builder, log_period)}
    diagram = builder.Build()
    diagram.set_name("cpfl_step")
    return Built(diagram, plant, {"controller": c, "motor": motor}, loggers, params)
