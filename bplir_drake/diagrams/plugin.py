"""Bring your own controller: the port contract of the swing diagram.

A controller plugin is a function ``factory(params) -> System`` named
``"module:factory"`` (``controller.plugin``, or ``--controller
module:factory`` on the command line; ``module`` is an importable module or
a ``.py`` file).  It receives the parameters with the **nominal** model only
(``true_plant`` / ``true_friction`` removed) and returns any Drake system
(a ``LeafSystem``, a ``Diagram``, C++ or Python) with

* input port ``state`` (4): the estimated state ``(q1, q2, q1d, q2d)``
  (rad, rad/s; relative elbow angle, SPEC.md conventions), the EKF's tick
  result, held over each controller tick ``T`` (``controller.period``), or
  the true state sampled at the tick with ``--true-state``;
* optional input port ``torque_available`` (1): the torque (N m) the
  driver can deliver now (for anti-windup);
* output port ``torque`` (1): the elbow torque command (N m).

The command is sampled by a zero-order hold at ``t_k + compute_latency``
(0.3 ms after the tick's IMU sample), delayed by the scenario's actuation
delay, and passes the motor and driver model (saturation, dead band, i^2 t
interlock).  The swing time is the context's time (the swing starts at
t = 0).  A system that breaks the contract is refused with a one-line
:class:`~bplir_drake.params.ParameterError` naming the port.
"""
from __future__ import annotations

import importlib
import importlib.util
import sys
from pathlib import Path

from ..params import BplirParams, ParameterError

#: (name, size, required) of the input ports a plugin may have
PLUGIN_INPUTS = (("state", 4, True), ("torque_available", 1, False))
#: (name, size) of its output port
PLUGIN_OUTPUT = ("torque", 1)


def load_factory(spec: str):
    """The function ``spec = "module:factory"`` names (one-line
    ``ParameterError`` when it cannot be loaded)."""
    module_name, name = spec.rsplit(":", 1)
    try:
        if module_name.endswith(".py"):
            path = Path(module_name)
            if not path.is_file():
                raise ParameterError(f"controller plugin {spec!r}: no file {path}")
            key = f"bplir_plugin_{abs(hash(str(path.resolve())))}"
            module = sys.modules.get(key)
            if module is None:
                loader = importlib.util.spec_from_file_location(key, path)
                module = importlib.util.module_from_spec(loader)
                loader.loader.exec_module(module)
                sys.modules[key] = module
        else:
            module = importlib.import_module(module_name)
    except ParameterError:
        raise
    except Exception as exc:  # noqa: BLE001 - a user's module may raise anything
        raise ParameterError(f"controller plugin {spec!r}: cannot load {module_name}: "
                             + " ".join(f"{type(exc).__name__}: {exc}".split())[:200]) from None
    factory = getattr(module, name, None)
    if not callable(factory):
        raise ParameterError(f"controller plugin {spec!r}: {module_name} has no function {name}")
    return factory


def nominal_only(params: BplirParams) -> BplirParams:
    """``params`` without the simulated robot: what a controller may know."""
    return params.with_(true_plant=None, true_friction=None)


def make_plugin(params: BplirParams):
    """The user's controller system for ``params.controller.plugin``,
    checked against the port contract."""
    spec = params.controller.plugin
    try:
        system = load_factory(spec)(nominal_only(params))
    except ParameterError:
        raise
    except Exception as exc:  # noqa: BLE001
        raise ParameterError(f"controller plugin {spec!r}: the factory raised "
                             + " ".join(f"{type(exc).__name__}: {exc}".split())[:200]) from None
    if not hasattr(system, "HasInputPort"):
        raise ParameterError(f"controller plugin {spec!r}: the factory must return a Drake "
                             f"system, got {type(system).__name__}")
    for name, size, required in PLUGIN_INPUTS:
        if system.HasInputPort(name):
            got = system.GetInputPort(name).size()
            if got != size:
                raise ParameterError(f"controller plugin {spec!r}: input port '{name}' has "
                                     f"size {got}; the contract says {size}")
        elif required:
            raise ParameterError(f"controller plugin {spec!r}: no input port '{name}' "
                                 f"(size {size}: q1, q2, q1d, q2d)")
    allowed = {n for n, _, _ in PLUGIN_INPUTS}
    for i in range(system.num_input_ports()):
        extra = system.get_input_port(i).get_name()
        if extra not in allowed:
            raise ParameterError(f"controller plugin {spec!r}: unknown input port '{extra}'; "
                                 "allowed: " + ", ".join(sorted(allowed)))
    name, size = PLUGIN_OUTPUT
    if not system.HasOutputPort(name) or system.GetOutputPort(name).size() != size:
        raise ParameterError(f"controller plugin {spec!r}: needs an output port '{name}' of "
                             f"size {size} (the elbow torque command, N m)")
    return system
