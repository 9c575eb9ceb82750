"""The motor's torque-speed envelope at the elbow, with a swing's operating
points on it: what a hardware engineer reads to see whether a swing is one
the real motor, driver and supply can make.

The envelope (:func:`bplir_drake.systems.motor.torque_window`): the driver's
current limit, and the voltage it can put across the winding less the
back-EMF, at every elbow rate.  Motoring (torque and rate of one sign) runs
out of voltage as the elbow speeds up; braking does not.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ...params import BplirParams
from ...systems.motor import envelope_curve, no_load_speed
from ...io import Result
from .model_plots import plot_envelope


@dataclass
class EnvelopeResult(Result):
    """The envelope at the supply voltage (and at ``other_voltage`` for
    comparison) and, optionally, a swing's operating points."""

    speeds: np.ndarray            # (n,) elbow rate (rad/s)
    torque: np.ndarray            # (n, 2) lowest / highest deliverable torque (N m)
    other_torque: np.ndarray      # (n, 2) the same at ``other_voltage``
    supply_voltage: float         # V
    other_voltage: float          # V
    max_voltage: float            # the driver's largest output (V)
    current_torque: float         # the torque of the peak current (N m)
    power_rating: float           # W
    no_load_speed: float          # elbow rate where the back-EMF takes all the voltage (rad/s)
    swing_rate: np.ndarray = field(default_factory=lambda: np.zeros(0))    # (N,) rad/s
    swing_torque: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (N,) N m
    swing_label: str = ""
    voltage_limited: bool = True  # the motor's voltage envelope is modelled (motor.envelope)

    def summary(self) -> dict:
        """The envelope's figures and the swing's peak rate and voltage margin."""
        out = {"voltage_envelope": self.voltage_limited,
               "current_limit_torque_Nm": self.current_torque}
        if self.voltage_limited:
            out |= {"supply_voltage_V": self.supply_voltage, "max_voltage_V": self.max_voltage,
                    "no_load_speed_rad_s": self.no_load_speed,
                    "corner_speed_rad_s": self.corner_speed(),
                    "max_mechanical_power_W": self.max_power()}
        if len(self.swing_rate):
            out["swing_peak_rate_rad_s"] = float(np.max(np.abs(self.swing_rate)))
        return out

    def corner_speed(self) -> float:
        """The elbow rate above which the full current is no longer available (rad/s)."""
        full = self.torque[:, 1] >= self.current_torque * (1 - 1e-9)
        pos = (self.speeds >= 0) & full
        return float(self.speeds[pos].max()) if pos.any() else 0.0

    def max_power(self) -> float:
        """The largest motoring power the envelope allows (W)."""
        return float(np.max(self.speeds * self.torque[:, 1]))

    def plot(self, axes=None):
        """The envelope and the operating points on one axes."""

        return plot_envelope(self, axes)


def torque_envelope(params: BplirParams, other_voltage: float = 48.0,
                    swing=None, n: int = 401) -> EnvelopeResult:
    """The elbow's torque-speed envelope of ``params.motor`` (its torque
    limit the smaller of the motor's and the controller's), at its supply
    and at ``other_voltage``; ``swing`` (a swing result) adds its operating
    points: the true elbow rate and the delivered torque of every log row."""
    limit = min(params.motor.torque_limit, params.controller.torque_limit)
    m = replace(params.motor, torque_limit=limit)
    other = replace(m, supply_voltage=other_voltage)
    top = 1.15 * max(no_load_speed(other), no_load_speed(m))
    speeds = np.linspace(-top, top, n)
    rate = torque = np.zeros(0)
    label = ""
    if swing is not None:
        rate = swing.logs["state"].data[:, 3]
        torque = swing.logs["torque"].data[:, 0]
        s = swing.summary
        label = (f"swing on a {s['incline_deg']:g} deg line, {s['outcome']}"
                 + (f" at {s['capture_speed_mps']:.2f} m/s"
                    if math.isfinite(s.get("capture_speed_mps") or math.nan) else ""))
    return EnvelopeResult(speeds, envelope_curve(m, speeds), envelope_curve(other, speeds),
                          m.supply_voltage, other_voltage, m.max_voltage,
                          min(limit, m.torque_per_amp * m.i_peak), m.power_rating,
                          no_load_speed(m), rate, torque, label, bool(m.envelope))


__all__ = ["EnvelopeResult", "torque_envelope"]
