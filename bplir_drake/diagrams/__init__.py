"""Builders that wire the BPLIR systems into the diagrams users run.

All wiring of ports happens in this package; analysis code calls these
builders.  Each builder takes one :class:`~bplir_drake.params.BplirParams`
and returns a :class:`Built`: the diagram and handles to its named
subsystems and loggers.  The simulated plant always uses
``params.simulated_plant`` / ``params.simulated_friction``; controllers and
estimators only ever see the nominal blocks.

* :mod:`.parts` -- :class:`Built` and the pieces every diagram shares (plant
  with friction, IMUs, sampling holds, schedule sources);
* :mod:`.open_loop` -- free swings, the plant to linearise, sensors + EKF;
* :mod:`.control` -- the CPFL loop on the true state (step tests, QFT plant);
* :mod:`.swing` -- the full closed loop of one swing, composed from named
  builders, and the Monte Carlo sample a context can carry
  (:func:`set_swing_sample`); :mod:`.swing_ports` -- its input and output
  ports, their signal names and the estimate's timing;
  :mod:`.linearize_guard` -- Drake's ``Linearize`` on a hybrid diagram
  answered in one line.
"""
from .cpfl_loop import build_control_loop, build_cpfl_plant, build_cpfl_step
from .open_loop import build_free_swing, build_plant_with_friction, build_sensor_swing
from .parts import Built, add_imus, add_plant_with_friction, sampled
from .swing import (
    SAMPLE_FIELDS, add_actuation, add_interlock, add_robot, add_sensing, add_swing_controller, add_swing_loggers, build_swing, set_pulses, set_swing_sample, swing_structure)
from .swing_setup import swing_geometry
from .swing_ports import SWING_INPUTS, SWING_PORTS, SWING_SIGNALS, estimate_times
from .linearize_guard import HybridLinearizeError, guard

guard()   # Drake's Linearize on a hybrid swing diagram: one line, not an abort

__all__ = ["Built", "sampled", "add_plant_with_friction", "add_imus", "build_free_swing",
           "build_plant_with_friction", "build_sensor_swing", "build_cpfl_plant",
           "build_control_loop", "build_cpfl_step", "swing_geometry", "build_swing",
           "SAMPLE_FIELDS", "swing_structure", "set_swing_sample", "set_pulses", "add_robot", "add_sensing",
           "add_swing_controller", "add_actuation", "add_interlock", "add_swing_loggers",
           "SWING_PORTS", "SWING_SIGNALS", "SWING_INPUTS", "estimate_times",
           "HybridLinearizeError"]
