"""Bring your own controller or estimator: the port contracts of the swing
diagram.

A plugin is a function ``factory(params) -> System`` named
``"module:factory"`` (``module`` is an importable module or a ``.py``
file): ``controller.plugin`` / ``estimator.plugin`` in the parameters,
``--controller`` / ``--estimator module:factory`` on the command line, or
the ``controller=`` / ``estimator=`` arguments of
:func:`~bplir_drake.diagrams.build_swing` (a spec or the factory itself).
The factory receives the parameters with the **nominal** model only
(``true_plant`` / ``true_friction`` removed) and returns any Drake system
(a ``LeafSystem``, a ``Diagram``, C++ or Python).

**Controller** (:data:`CONTROLLER`)

* input port ``state`` (4): the state ``(q1, q2, q1d, q2d)`` (rad, rad/s;
  relative elbow angle, the conventions of docs/concepts.md) from the estimator, its
  tick-k result, held over the controller tick ``T``
  (``controller.period``), or the true state sampled at the tick with
  ``--true-state``;
* optional input port ``torque_available`` (1): the torque (N m) the
  driver can deliver now (for anti-windup);
* optional input port ``imu`` (6): the IMU sample of the tick, as the
  estimator reads it (below);
* output port ``torque`` (1): the elbow torque command (N m).

The command is sampled by a zero-order hold at ``t_k + compute_latency``
(0.3 ms after the tick's IMU sample), delayed by the scenario's actuation
delay, and passes the motor and driver model (saturation, dead band, i^2 t
interlock).  The swing time is the context's time (the swing starts at
t = 0).

**Estimator** (:data:`ESTIMATOR`)

* input port ``imu`` (6): the two IMUs' sample k, ``(gyro1, gyro2,
  acc1_x, acc1_y, acc2_x, acc2_y)`` (rad/s, m/s^2; gyro i reads link i's
  absolute rate, ``omega_1 = q1d``, ``omega_2 = q1d + q2d``; accelerometer
  i the specific force in its link's frame, x tangential towards
  increasing angle, y along the link towards its proximal joint, ``+g``
  hanging at rest; :mod:`bplir_drake.systems.imu`), taken at ``t_k = k T``
  and held until ``t_{k+1}``, with every error the scenario draws (noise,
  bias, scale, misalignment);
* output port ``state`` (4): the estimated ``(q1, q2, q1d, q2d)`` the
  controller reads within the same tick (so an output computed from the
  input is used at once; one computed from discrete state updated at
  ``t_k`` reflects sample k-1).

The robot starts at rest at the nominal start pose
(``swing_geometry(params)[0]``).  A system that breaks its contract is
refused with a one-line :class:`~bplir_drake.params.ParameterError` naming
the port.
"""
from __future__ import annotations

import importlib
import importlib.util
import sys
from dataclasses import dataclass
from pathlib import Path

from ..io import WallClockLimit, wall_clock_limit
from ..params import BplirParams, ParameterError, plugin_arguments, registered_plugins


@dataclass(frozen=True)
class PortContract:
    """What a plugin of one ``kind`` must offer: ``inputs`` are ``(name,
    size, required, meaning)``, ``output`` is ``(name, size, meaning)``."""

    kind: str
    inputs: tuple
    output: tuple


#: the contract of a controller plugin
CONTROLLER = PortContract("controller", (("state", 4, True, "q1, q2, q1d, q2d"),
                                         ("torque_available", 1, False, "N m"),
                                         ("imu", 6, False, "gyro1, gyro2, acc1_x, acc1_y, "
                                          "acc2_x, acc2_y")),
                          ("torque", 1, "the elbow torque command, N m"))
#: the contract of an estimator plugin
ESTIMATOR = PortContract("estimator", (("imu", 6, True,
                                        "gyro1, gyro2, acc1_x, acc1_y, acc2_x, acc2_y"),),
                         ("state", 4, "q1, q2, q1d, q2d"))
CONTRACTS = {c.kind: c for c in (CONTROLLER, ESTIMATOR)}


def load_factory(spec: str, kind: str = "controller"):
    """The function ``spec = "module:factory"`` names (one-line
    ``ParameterError`` when it cannot be loaded)."""
    if ":" not in spec:   # a registered name: its entry point's module:factory
        target = registered_plugins(kind).get(spec)
        if target is None:
            raise ParameterError(f"{kind} plugin {spec!r} is not registered; registered: "
                                 + (", ".join(sorted(registered_plugins(kind))) or "none"))
        spec = target
    module_name, name = spec.rsplit(":", 1)
    try:
        if module_name.endswith(".py"):
            path = Path(module_name)
            if not path.is_file():
                raise ParameterError(f"{kind} plugin {spec!r}: no file {path}")
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
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - a user's module may raise anything
        raise ParameterError(f"{kind} plugin {spec!r}: cannot load {module_name}: "
                             + _one_line(exc)) from None
    factory = getattr(module, name, None)
    if not callable(factory):
        raise ParameterError(f"{kind} plugin {spec!r}: {module_name} has no function {name}")
    return factory


def _one_line(exc: BaseException) -> str:
    return " ".join(f"{type(exc).__name__}: {exc}".split())[:200]


def nominal_only(params: BplirParams) -> BplirParams:
    """``params`` without the simulated robot: what a plugin may know."""
    return params.with_(true_plant=None, true_friction=None)


def make_plugin(params: BplirParams, kind: str = "controller", factory=None):
    """The user's system of ``kind`` (``"controller"`` or ``"estimator"``)
    for ``params.<kind>.plugin`` (or from ``factory``, a callable),
    checked against its :class:`PortContract`."""
    contract = CONTRACTS[kind]
    spec = getattr(params, kind).plugin if factory is None else getattr(
        factory, "__qualname__", repr(factory))
    kwargs = plugin_arguments(getattr(params, kind).plugin_args)
    try:
        with wall_clock_limit(params.scenario.wall_limit,
                              f"the {kind} plugin {spec!r} (its module and factory)"):
            make = load_factory(spec, kind) if factory is None else factory
            system = make(nominal_only(params), **kwargs)
    except (ParameterError, WallClockLimit):
        raise
    except (Exception, SystemExit) as exc:  # noqa: BLE001 - sys.exit() included
        raise ParameterError(f"{kind} plugin {spec!r}: the factory raised "
                             + _one_line(exc)) from None
    check_contract(system, contract, spec)
    return system


def check_contract(system, contract: PortContract, spec: str) -> None:
    """Raise a one-line ``ParameterError`` naming the first port of
    ``system`` that breaks ``contract``."""
    who = f"{contract.kind} plugin {spec!r}"
    if not hasattr(system, "HasInputPort"):
        raise ParameterError(f"{who}: the factory must return a Drake system, got "
                             f"{type(system).__name__}")
    for name, size, required, meaning in contract.inputs:
        if system.HasInputPort(name):
            got = system.GetInputPort(name).size()
            if got != size:
                raise ParameterError(f"{who}: input port '{name}' has size {got}; the contract "
                                     f"says {size} ({meaning})")
        elif required:
            raise ParameterError(f"{who}: no input port '{name}' (size {size}: {meaning})")
    allowed = {n for n, *_ in contract.inputs}
    for i in range(system.num_input_ports()):
        extra = system.get_input_port(i).get_name()
        if extra not in allowed:
            raise ParameterError(f"{who}: unknown input port '{extra}'; allowed: "
                                 + ", ".join(sorted(allowed)))
    name, size, meaning = contract.output
    if not system.HasOutputPort(name) or system.GetOutputPort(name).size() != size:
        raise ParameterError(f"{who}: needs an output port '{name}' of size {size} ({meaning})")
