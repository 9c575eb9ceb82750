"""What commissioning a robot gives: :class:`CommissionResult`."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...io import Result, package_version
from ...params import BplirParams
from .margins import unbalanced
from .commission_report import plot_commission


@dataclass
class CommissionResult(Result):
    """A commissioned robot: its grids of plans (``points``: a
    :class:`~.rows.PlanPoint` each, the gripper it holds with, how it was
    solved and its figures), the verification study at each incline and
    holding gripper (``studies``: a :class:`~.rows.StudyVerdict` each),
    the electric margins of its plans, ``limits``: one line per manoeuvre
    without a plan or study below the bar, with the reason and the number
    that shows it, and ``unshown``: one line per study whose capture rate is
    above the bar but whose Wilson interval is not, with the swings that
    would show it (both empty: ready)."""

    name: str
    params: BplirParams
    points: list
    studies: list
    limits: list
    unshown: list = field(default_factory=list)
    margins: dict = field(default_factory=dict)
    #: the elbow's effective peak torque and rates (:func:`~.margins.motor_figures`)
    motor: dict = field(default_factory=dict)
    #: by holding gripper, the line naming the limit that binds its plans
    binding: dict = field(default_factory=dict)
    #: what commissioning assumed where the description was silent
    assumed: list = field(default_factory=list)
    seed: int = 0
    wall_s: float = math.nan

    @property
    def ready(self) -> bool:
        """Every requested manoeuvre has a plan and its study shows it
        ready (the Wilson interval's lower end at or above the bar)."""
        return not self.limits and not self.unshown and bool(self.studies)

    @property
    def verdict(self) -> str:
        """"ready", "not shown" (every manoeuvre planned and captured above
        the bar, some study too small to show it) or "not ready"."""
        if self.ready:
            return "ready"
        return "not shown" if self.unshown and not self.limits else "not ready"

    @property
    def manoeuvre(self) -> str:
        """The ``scenario.manoeuvre`` that does what this commission chose
        for each gripper (``"swing,pump"``: a swing held by gripper 1, a pump
        by gripper 2), with which a traversal uses the verified plans."""
        chosen = {st.holding: st.manoeuvre for st in self.studies if st.chosen}
        kinds = [chosen.get(g, "swing") for g in (1, 2)]
        return kinds[0] if kinds[0] == kinds[1] else ",".join(kinds)

    def summary(self) -> dict:
        """The ``--json`` object: ``ready``, ``studies``, ``limits``,
        ``plans`` (solved, from similarity), ``wall_s`` and the details."""
        how = [p.how for p in self.points]
        return dict(
            robot=self.name, ready=self.ready, verdict=self.verdict, manoeuvre=self.manoeuvre,
            studies=[dict(holding=s.holding, incline_deg=s.incline_deg, captured=s.captured,
                          samples=s.samples, capture_speed_p95_mps=s.capture_speed_p95_mps,
                          capture_speed_p50_mps=s.capture_speed_p50_mps,
                          wilson95=s.wilson95, verdict=s.verdict,
                          samples_to_show=s.samples_to_show,
                          seed=s.seed, outcomes=s.outcomes, impact=s.impact,
                          manoeuvre=s.manoeuvre, chosen=s.chosen,
                          peak_voltage_V=s.peak_voltage_V, peak_torque_Nm=s.peak_torque_Nm)
                     for s in self.studies],
            limits=list(self.limits), unshown=list(self.unshown),
            plans=dict(points=len(how), solved=sum(h != "none" for h in how),
                       from_similarity=how.count("similarity"),
                       from_continuation=how.count("continuation"),
                       from_straight_line=how.count("straight line")),
            margins=self.margins, motor=self.motor,
            binding={str(g): x for g, x in self.binding.items()}, assumed=list(self.assumed),
            unbalanced=unbalanced(self.points), flat_line=self.flat_line(), seed=self.seed,
            wall_s=self.wall_s, grid=self.points, package_version=package_version())

    def flat_line(self) -> dict:
        """On a flat line, from the 0 deg plan at the robot's own spacing:
        the elbow's work per metre and the energy drawn from the supply per
        metre, the motor's losses included (J/m), and the swinging speed
        (m/min), swinging alone (no riding, no re-grip)."""
        d = self.params.scenario.grip_spacing
        rows = [p for p in self.points if p.incline_deg == 0.0 and p.spacing_m == d
                and p.how != "none" and p.holding == 1
                and p.start == "line" and p.chosen]
        if not rows:
            return {}
        r = rows[0]
        return dict(energy_per_m_J=r.get("energy_in_J", math.nan) / d,
                    supply_energy_per_m_J=r.get("supply_energy_J", math.nan) / d,
                    metres_per_min=60.0 * d / r.duration_s)

    def table(self):
        """The grid of plans, a row per point."""
        return [dict(p) for p in self.points]

    def to_pandas(self, what: str = "plans"):
        """The grid of plans (``what="plans"``, :meth:`table`) or the
        verification studies (``"studies"``, a row each) as a
        ``pandas.DataFrame``."""
        if what not in ("plans", "studies"):
            raise ValueError(f"what = {what!r}; allowed 'plans' or 'studies'")
        frame = super().to_pandas()
        if what == "plans":
            return frame
        return frame.__class__([{k: v for k, v in dict(st).items()
                                 if not isinstance(v, (dict, list, tuple))}
                                for st in self.studies])

    def plot(self, axes=None):
        """The grid's plans (duration, peak torque) and the studies'
        capture rates with their Wilson intervals."""
        return plot_commission(self, axes)

    def rate(self, incline: float, holding: int = 1) -> float:
        """The verification study's capture rate at ``incline`` holding with
        gripper ``holding`` by the manoeuvre chosen (nan: none)."""
        for s in self.studies:
            if np.isclose(s.incline_deg, incline) and s.holding == holding \
                    and s.chosen:
                return s.rate
        return math.nan
