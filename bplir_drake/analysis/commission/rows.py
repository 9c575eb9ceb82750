"""The rows of a commissioned robot, read by attribute: a grid point of its
libraries (:class:`PlanPoint`) and a verification study's line
(:class:`StudyVerdict`); each is the dict its ``commission.json`` holds."""
from __future__ import annotations

import math

from ...io import Record


class _Row(Record):
    """A row whose optional fields have their defaults."""

    DEFAULTS: dict = {}

    def __init__(self, *args, **fields):
        super().__init__(self.DEFAULTS)
        self.update(dict(*args, **fields))


class PlanPoint(_Row):
    """One point of a commissioned grid: where it is (``incline_deg``,
    ``spacing_m``), its manoeuvre (``holding``: the gripper; ``start``: line
    or hanging; ``manoeuvre``: swing or pump; ``chosen``: False for the
    manoeuvre commissioning did not keep), how its plan was solved (``how``:
    similarity, continuation, straight line or none; ``status``, ``tried``,
    ``wall_s``) and the plan's figures (``duration_s``, ``peak_torque_Nm``,
    ``peak_voltage_V``, ``energy_in_J``, ``supply_energy_J``,
    ``energy_residual_share``; NaN without a plan)."""

    DEFAULTS = dict(start="line", manoeuvre="swing", chosen=True,
                    energy_residual_share=math.nan)


class StudyVerdict(_Row):
    """A verification study's line: its incline (``incline_deg``) and
    manoeuvre (``holding``, ``manoeuvre``, ``chosen``), the swings captured
    of ``samples`` (``captured``, ``rate``, ``wilson95``, ``outcomes``), the
    ``verdict`` (ready, not shown or below) with ``samples_to_show``, the
    capture speed's p50 and p95, the peak voltage and torque, the root
    ``seed`` and the landing's ``impact`` (None where not worked out)."""

    DEFAULTS = dict(manoeuvre="swing", chosen=True, impact=None, verdict=None,
                    samples_to_show=None, seed=None)
