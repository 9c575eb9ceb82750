"""A swing's summary as a typed record: every figure a named field with its
unit and meaning in the field's metadata.

:class:`SwingSummary` reads like a mapping too (``summary["capture_speed_mps"]``,
``dict(summary)``, ``summary | extra``), so files keep their keys:
:meth:`SwingSummary.to_dict` is what ``summary.json`` and the study rows hold.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields

from ...io import dumps_strict


def _f(unit: str, doc: str, default=math.nan):
    """A summary field with its unit and one-line meaning."""
    return field(default=default, metadata={"unit": unit, "doc": doc})


def _box(unit: str, doc: str):
    """A field holding a list or table (no default value)."""
    return field(default=None, metadata={"unit": unit, "doc": doc})


@dataclass(frozen=True)
class SwingSummary(Mapping):
    """The outcome of one swing and its figures (see each field's metadata:
    ``SwingSummary.units()``, ``SwingSummary.docs()``)."""

    success: bool = _f("", "the gripper captured the line within every threshold", False)
    outcome: str = _f("", "captured, crash, short, fall or timeout", "")
    swing_time_s: float = _f("s", "time of the interlock's decision")
    capture_distance_m: float = _f("m", "gripper-to-line distance at the decision")
    capture_speed_mps: float = _f("m/s", "gripper speed at arrival")
    closest_distance_m: float = _f("m", "closest the gripper came to the line")
    travel_m: float = _f("m", "distance along the line from the holding gripper at arrival")
    landing_error_m: float = _f("m", "arrival along the line less the planned grip (2 D)")
    landing_height_error_m: float = _f("m", "the robot's own estimate of the gripper's height "
                                            "at arrival less the truth")
    estimated_peak_height_m: float = _f("m", "the highest the robot's estimate put the gripper "
                                             "ahead of the holding gripper (negative: below the line)")
    fixed_gripper_open: bool = _f("", "the holding gripper was released", False)
    peak_torque_Nm: float = _f("N m", "largest elbow torque applied")
    peak_motor_power_W: float = _f("W", "largest mechanical elbow power")
    motor_power_rating_W: float = _f("W", "the motor's rated power")
    within_power_rating: bool = _f("", "the peak power stayed within the rating", False)
    energy_in_J: float = _f("J", "net mechanical work of the elbow")
    supply_voltage_V: float = _f("V", "the driver's supply")
    max_voltage_V: float = _f("V", "the driver's largest output voltage")
    peak_voltage_V: float = _f("V", "largest winding voltage")
    on_envelope_s: float = _f("s", "time the current was held by the voltage envelope")
    electrical_energy_J: float = _f("J", "net electrical energy drawn from the supply")
    regenerated_J: float = _f("J", "electrical energy braked back into the supply")
    max_estimation_error_rad: float = _f("rad", "largest angle error of the in-loop estimate")
    final_configuration_rad: list = _box("rad", "q1, q2 at the decision")
    target_configuration_rad: list = _box("rad", "q1, q2 of the planned grip")
    mirror_error_rad: float = _f("rad", "largest angle difference to the target at the end")
    delay_identified_s: float = _f("s", "actuation delay the controller identified (nan: none)")
    delay_fit_ratio: float = _f("", "the delay identifier's fit ratio (nan: none)")
    estimator_in_loop: bool = _f("", "the controller read the estimate (not the truth)", True)
    controller: str = _f("", "the controller preset or plug-in's name", "")
    path_mode: str = _f("", "how the swing was steered (plan, adaptive, ...)", "")
    incline_deg: float = _f("deg", "line incline")
    grip_spacing_m: float = _f("m", "grip spacing D")
    seed: int = _f("", "seed of the swing's random draws", 0)
    thresholds: dict = _box("", "the success thresholds the swing was judged by")
    true_friction: dict = _box("", "the simulated robot's friction (drawn from the seed)")
    start_configuration_rad: list = _box("rad", "q1, q2 at the start")
    i2t_start_A2s: float = _f("A^2 s", "the driver's i^2 t state at the start")
    i2t_end_A2s: float = _f("A^2 s", "the driver's i^2 t state at the end")
    driver_tripped_end: bool = _f("", "the driver's i^2 t interlock was tripped at the end",
                                  False)
    driver_tripped: bool = _f("", "the driver's interlock tripped during the swing", False)

    # the mapping view: the keys files have always had
    def __getitem__(self, key: str):
        if key not in self._names():
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self):
        return iter(self._names())

    def __len__(self) -> int:
        return len(self._names())

    def __or__(self, other) -> dict:
        return self.to_dict() | dict(other)

    def __ror__(self, other) -> dict:
        return dict(other) | self.to_dict()

    @classmethod
    def _names(cls) -> tuple[str, ...]:
        return tuple(f.name for f in fields(cls))

    @classmethod
    def units(cls) -> dict[str, str]:
        """Each field's unit ('' for a flag, a name or a count)."""
        return {f.name: f.metadata["unit"] for f in fields(cls)}

    @classmethod
    def docs(cls) -> dict[str, str]:
        """Each field's one-line meaning."""
        return {f.name: f.metadata["doc"] for f in fields(cls)}

    def to_dict(self) -> dict:
        """The summary as a plain dict, the keys of ``summary.json``."""
        return {name: getattr(self, name) for name in self._names()}

    def __call__(self) -> dict:
        """:meth:`to_dict`: a swing's ``result.summary()`` as every result's
        (``result.summary["outcome"]`` and ``result.summary.outcome`` read
        one field)."""
        return self.to_dict()

    def to_json(self) -> str:
        """:meth:`to_dict` as strict JSON text (NaN and infinity as null)."""
        return dumps_strict(self.to_dict())
