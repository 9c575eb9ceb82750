"""A traversal's result: its segments (rides and swings), the outcome and the rows of every swing."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from ...params import BplirParams
from ...io import Record, Result
from .line import Line
from .traverse_plots import plot_line_grips


#: traversal outcomes: passed, or the first thing that went wrong
OUTCOMES = ("passed", "swing crash", "swing timeout", "swing fault", "landed on obstacle",
            "driver trip", "error")


ROW_FIELDS = ("index", "kind", "obstacle", "holding_gripper", "robot", "t_start_s", "duration_s",
              "hold_m", "from_m", "to_m", "incline_deg", "outcome", "capture_speed_mps",
              "capture_impulse_Ns", "effective_mass_kg", "peak_torque_Nm", "peak_power_W",
              "peak_voltage_V", "energy_J", "i2t_start_A2s", "i2t_end_A2s", "landing_bias_m",
              "landing_height_error_m", "seed", "attempt")


class TraverseRow(Record):
    """One manoeuvre of a traversal (a ride, a rest, a calibration, a swing
    or a try of one, a damping): the fields of :data:`ROW_FIELDS`, read as
    attributes (``row.outcome``) or as the keys of ``manoeuvres.csv``."""


class TraverseTotals(Record):
    """A traversal's totals (outcome, obstacles passed, times, energies,
    the worst figures of its swings), read as attributes or as the keys of
    ``traverse.json``'s ``totals``."""


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


#: the motion log's columns: time, angles, gripper 1's pose, torque, current, i^2 t
MOTION_COLUMNS = ("t", "q1", "q2", "x", "y", "z", "torque", "current", "i2t")
MOTION_UNITS = ("s", "rad", "rad", "m", "m", "m", "N m", "A", "A^2 s")
#: how a motion log file is laid out (``bplir traverse`` writes it into traverse.json)
MOTION_FORMAT = {"dtype": "little-endian float64, no header, one row per sample",
                 "columns": [f"{c} ({u})" for c, u in zip(MOTION_COLUMNS, MOTION_UNITS)],
                 "read_with": f"numpy.fromfile(path, '<f8').reshape(-1, {len(MOTION_COLUMNS)})"}


class MotionLog:
    """The traversal's motion, segment by segment (:class:`Segment`): kept
    in memory (``path=None``), appended to ``path`` as it goes (raw float64
    rows of :data:`MOTION_COLUMNS`: memory stays bounded on any line) or
    not kept (``path=False``: a study's traversals)."""

    def __init__(self, path=None):
        self.path = None if path is None or path is False else Path(path)
        self.keep = path is not False
        self._segments: list = []
        self.samples = 0
        self.peak_i2t = 0.0   # the highest i^2 t of any manoeuvre, kept or not (A^2 s)
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.path.write_bytes(b"")

    def append(self, seg: Segment) -> None:
        """Add one manoeuvre's motion (to the file at once, when there is one)."""
        if len(seg.i2t):
            self.peak_i2t = max(self.peak_i2t, float(np.max(seg.i2t)))
        if not self.keep:
            return
        self.samples += len(seg.t)
        if self.path is None:
            self._segments.append(seg)
            return
        rows = np.column_stack([seg.t, seg.q, seg.base, seg.torque, seg.current, seg.i2t])
        try:
            with open(self.path, "ab") as fh:
                fh.write(np.ascontiguousarray(rows, dtype="<f8").tobytes())
        except OSError as exc:   # a full disk: name the file
            raise OSError(exc.errno, exc.strerror, str(self.path)) from exc

    def arrays(self, max_samples: int | None = None) -> dict:
        """``t``, ``q``, ``base``, ``torque``, ``current``, ``i2t`` of the
        whole traversal, every k-th sample so that at most ``max_samples``
        are read (the file is memory-mapped, not loaded)."""
        if self.path is not None:
            n = self.path.stat().st_size // (8 * len(MOTION_COLUMNS))
            data = np.memmap(self.path, dtype="<f8", mode="r", shape=(n, len(MOTION_COLUMNS)))
        elif self._segments:
            data = np.concatenate([np.column_stack([s.t, s.q, s.base, s.torque, s.current,
                                                    s.i2t]) for s in self._segments])
        else:
            data = np.zeros((0, len(MOTION_COLUMNS)))
        step = max(1, -(-len(data) // max_samples)) if max_samples else 1
        data = np.array(data[::step])
        return {"t": data[:, 0], "q": data[:, 1:3], "base": data[:, 3:6],
                "torque": data[:, 6], "current": data[:, 7], "i2t": data[:, 8]}


@dataclass
class TraverseResult(Result):
    """One traversal: ``rows`` (one dict per manoeuvre, :data:`ROW_FIELDS`),
    ``totals``, the line, the parameters and seed, and the ``motion``
    (:class:`MotionLog`, for figures and the replay)."""

    line: Line
    params: BplirParams
    seed: int
    rows: list
    totals: dict
    motion: MotionLog = field(default_factory=MotionLog)
    clamps: list = field(default_factory=list)   # (gripper, s, t_on, t_off): clamped in place
    holds: list = field(default_factory=list)    # (gripper, t_closed, t_opened): on the line
    knocks: dict | None = None   # a knocked run's knocks: their rule and one row each

    @property
    def success(self) -> bool:
        """Every obstacle passed, no driver trip, no fall."""
        return self.totals.outcome == "passed"

    def sample_fields(self) -> dict:
        """The fields a traversal study keeps per sample: the totals, the
        worst swing's figures under the swing fields' names (``capture_speed_mps``:
        the fastest capture; ``swing_time_s``, ``energy_in_J``: all swings)."""
        t = self.totals
        return t | {"swing_time_s": t.swing_time_s, "energy_in_J": t.energy_swing_J}

    def table(self) -> list:
        """The manoeuvres, one row each (:data:`ROW_FIELDS`)."""
        return self.rows

    def summary(self) -> dict:
        """Totals and the per-manoeuvre table (JSON-ready)."""
        return {"totals": self.totals, "manoeuvres": self.rows,
                "holds": [{"gripper": g, "closed_s": t_on, "opened_s": t_off}
                          for g, t_on, t_off in self.holds],
                "clamps": [{"gripper": g, "at_m": at, "from_s": t_on, "to_s": t_off}
                           for g, at, t_on, t_off in self.clamps],
                "line": self.line.data, "seed": self.seed} | (
                    {"knocks": self.knocks} if self.knocks is not None else {})

    def timeline(self, max_samples: int | None = None) -> dict:
        """The whole traversal's motion (:meth:`MotionLog.arrays`): ``t``,
        ``q``, ``base``, ``torque``, ``current``, ``i2t`` arrays."""
        out = self.motion.arrays(max_samples)
        # link 1 turns over while gripper 1 swings (it hangs below the elbow
        # at the bottom of the swing): continuous angles, not wrapped ones
        out["q"] = np.unwrap(out["q"], axis=0)
        return out

    def plot(self, axes=None):
        """The line with its obstacles and every grip (one axis)."""

        return plot_line_grips(self, axes)
