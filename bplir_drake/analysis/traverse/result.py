"""A traversal's result: its segments (rides and swings), the outcome and the rows of every swing."""
from __future__ import annotations

from dataclasses import dataclass, field
import numpy as np
from ...params import BplirParams
from ...io import Result
from .line import Line
from .plots import plot_line_grips


#: traversal outcomes: passed, or the first thing that went wrong
OUTCOMES = ("passed", "swing crash", "swing timeout", "swing fault", "landed on obstacle",
            "driver trip", "error")


ROW_FIELDS = ("index", "kind", "obstacle", "holding_gripper", "robot", "t_start_s", "duration_s",
              "hold_m", "from_m", "to_m", "incline_deg", "outcome", "capture_speed_mps",
              "capture_impulse_Ns", "effective_mass_kg", "peak_torque_Nm", "peak_power_W",
              "peak_voltage_V", "energy_J", "i2t_start_A2s", "i2t_end_A2s", "landing_bias_m",
              "landing_height_error_m", "seed", "attempt")


@dataclass
class Segment:
    """The motion of one manoeuvre for the figures and the animation: times
    (s, traversal clock), joint angles of the original robot (n x 2, rad),
    the pose of gripper 1 (n x 3: x, y, 0), elbow torque (N m), current (A),
    i^2 t (A^2 s)."""

    t: np.ndarray
    q: np.ndarray
    base: np.ndarray
    torque: np.ndarray
    current: np.ndarray
    i2t: np.ndarray


@dataclass
class TraverseResult(Result):
    """One traversal: ``rows`` (one dict per manoeuvre, :data:`ROW_FIELDS`),
    ``totals``, the line, the parameters and seed, and the motion
    ``segments`` (for figures and the replay)."""

    line: Line
    params: BplirParams
    seed: int
    rows: list
    totals: dict
    segments: list = field(default_factory=list)
    clamps: list = field(default_factory=list)   # (gripper, s, t_on, t_off): clamped in place
    holds: list = field(default_factory=list)    # (gripper, t_closed, t_opened): on the line

    @property
    def success(self) -> bool:
        """Every obstacle passed, no driver trip, no fall."""
        return self.totals["outcome"] == "passed"

    def sample_fields(self) -> dict:
        """The fields a traversal study keeps per sample: the totals, the
        worst swing's figures under the swing fields' names (``capture_speed_mps``:
        the fastest capture; ``swing_time_s``, ``energy_in_J``: all swings)."""
        t = self.totals
        return t | {"swing_time_s": t["swing_time_s"], "energy_in_J": t["energy_swing_J"]}

    def summary(self) -> dict:
        """Totals and the per-manoeuvre table (JSON-ready)."""
        return {"totals": self.totals, "manoeuvres": self.rows,
                "holds": [{"gripper": g, "closed_s": t_on, "opened_s": t_off}
                          for g, t_on, t_off in self.holds],
                "clamps": [{"gripper": g, "at_m": at, "from_s": t_on, "to_s": t_off}
                           for g, at, t_on, t_off in self.clamps],
                "line": self.line.data, "seed": self.seed}

    def timeline(self) -> dict:
        """The whole traversal's motion concatenated: ``t``, ``q``, ``base``,
        ``torque``, ``current``, ``i2t`` arrays."""
        keys = ("t", "q", "base", "torque", "current", "i2t")
        out = {k: np.concatenate([getattr(s, k) for s in self.segments]) for k in keys}
        # link 1 turns over while gripper 1 swings (it hangs below the elbow
        # at the bottom of the swing): continuous angles, not wrapped ones
        out["q"] = np.unwrap(out["q"], axis=0)
        return out

    def plot(self, axes=None):
        """The line with its obstacles and every grip (one axis)."""

        return plot_line_grips(self, axes)
