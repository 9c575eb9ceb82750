"""What commissioning a robot gives: :class:`CommissionResult`."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...io import Result, package_version
from ...params import BplirParams
from .report import plot_commission


@dataclass
class CommissionResult(Result):
    """A commissioned robot: its grids of plans (``points``: a row each, the
    gripper it holds with, how it was solved and its figures), the
    verification study at each incline and holding gripper (``studies``),
    the electric margins of its plans, and ``limits``: one
    line per manoeuvre without a plan or study below the bar, with the
    physical reason and the number that shows it (empty: ready)."""

    name: str
    params: BplirParams
    points: list
    studies: list
    limits: list
    margins: dict = field(default_factory=dict)
    seed: int = 0
    wall_s: float = math.nan

    @property
    def ready(self) -> bool:
        """Every requested manoeuvre has a plan and passes its study."""
        return not self.limits and bool(self.studies)

    def summary(self) -> dict:
        """The ``--json`` object: ``ready``, ``studies``, ``limits``,
        ``plans`` (solved, from similarity), ``wall_s`` and the details."""
        how = [p["how"] for p in self.points]
        return dict(
            robot=self.name, ready=self.ready,
            studies=[dict(holding=s["holding"], incline_deg=s["incline_deg"], captured=s["captured"],
                          samples=s["samples"], capture_speed_p95_mps=s["capture_speed_p95_mps"],
                          capture_speed_p50_mps=s["capture_speed_p50_mps"],
                          wilson95=s["wilson95"], seed=s["seed"], outcomes=s["outcomes"],
                          peak_voltage_V=s["peak_voltage_V"], peak_torque_Nm=s["peak_torque_Nm"])
                     for s in self.studies],
            limits=list(self.limits),
            plans=dict(points=len(how), solved=sum(h != "none" for h in how),
                       from_similarity=how.count("similarity"),
                       from_continuation=how.count("continuation"),
                       from_straight_line=how.count("straight line")),
            margins=self.margins, flat_line=self.flat_line(), seed=self.seed,
            wall_s=self.wall_s, grid=self.points, package_version=package_version())

    def flat_line(self) -> dict:
        """On a flat line, from the 0 deg plan at the robot's own spacing:
        the elbow's work per metre (J/m) and the swinging speed (m/min),
        swinging alone (no riding, no re-grip)."""
        d = self.params.scenario.grip_spacing
        rows = [p for p in self.points if p["incline_deg"] == 0.0 and p["spacing_m"] == d
                and p["how"] != "none" and p["holding"] == 1
                and p.get("start", "line") == "line"]
        if not rows:
            return {}
        r = rows[0]
        return dict(energy_per_m_J=r.get("energy_in_J", math.nan) / d,
                    metres_per_min=60.0 * d / r["duration_s"])

    def table(self):
        """The grid of plans, a row per point."""
        return [dict(p) for p in self.points]

    def plot(self, axes=None):
        """The grid's plans (duration, peak torque) and the studies'
        capture rates with their Wilson intervals."""
        return plot_commission(self, axes)

    def rate(self, incline: float, holding: int = 1) -> float:
        """The verification study's capture rate at ``incline`` holding with
        gripper ``holding`` (nan: none)."""
        for s in self.studies:
            if np.isclose(s["incline_deg"], incline) and s["holding"] == holding:
                return s["rate"]
        return math.nan
