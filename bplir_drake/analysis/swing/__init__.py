"""One brachiation swing: running it, comparing presets, planning it.

* :mod:`.swing_runner` -- :func:`~.swing_runner.run_swing`,
  :class:`~.swing_runner.SwingRunner` (one diagram for many samples),
  :func:`~.swing_runner.swing_diagram` (the diagram with its plan's gains),
  :class:`~.swing_runner.SwingResult`; :mod:`.logs` -- log export;
* :mod:`.compare` -- the controller presets on one scenario;
* the plans and their tracking gains live one layer down, in
  :mod:`bplir_drake.planning.solve` (cached by :mod:`bplir_drake.planning.cache`);
* :mod:`.summary` -- :class:`~.summary.SwingSummary`, the typed summary;
* :mod:`.swing_plots` -- plots and animation of a swing result.

``bplir_drake.analysis.swing.run`` and ``bplir_drake.analysis.swing.plan``
are the 0.1.0 import paths of the run and of the planner's three public
names, kept as shims.
"""
import sys as _sys
import types as _types

from ...planning.solve import plan_swing as _plan_swing, tracking_plan as _tracking_plan
from ...planning.swing_plan import SwingPlan as _SwingPlan
from .swing_runner import (
    SWING_ACCURACY, SWING_INTEGRATOR, SwingResult, SwingRunner, run_swing, swing_diagram)
from .summary import SwingSummary

__all__ = ["SWING_ACCURACY", "SWING_INTEGRATOR", "SwingResult", "SwingRunner", "SwingSummary",
           "run_swing", "swing_diagram"]

# 0.1.0's ``bplir_drake.analysis.swing.plan`` (the planner is bplir_drake.planning now)
_plan = _types.ModuleType(__name__ + ".plan", "The 0.1.0 import path of the planner's public "
                          "names: plan_swing, tracking_plan, SwingPlan (bplir_drake.planning).")
_plan.plan_swing, _plan.tracking_plan, _plan.SwingPlan = _plan_swing, _tracking_plan, _SwingPlan
_plan.__all__ = ["plan_swing", "tracking_plan", "SwingPlan"]
_sys.modules.setdefault(_plan.__name__, _plan)
