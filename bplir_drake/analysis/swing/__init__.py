"""One brachiation swing: running it, comparing presets, planning it.

* :mod:`.run` -- :func:`~.run.run_swing`, :class:`~.run.SwingRunner` (one
  diagram for many samples), :func:`~.run.swing_diagram` (the diagram with
  its plan's gains), :class:`~.run.SwingResult`, log export;
* :mod:`.compare` -- the controller presets on one scenario;
* the plans and their tracking gains live one layer down, in
  :mod:`bplir_drake.planning.solve` (cached by :mod:`bplir_drake.planning.cache`);
* :mod:`.summary` -- :class:`~.summary.SwingSummary`, the typed summary;
* :mod:`.plots` -- plots and animation of a swing result.
"""
from .swing_runner import (
    SWING_ACCURACY, SWING_INTEGRATOR, SwingResult, SwingRunner, run_swing, swing_diagram)
from .summary import SwingSummary

__all__ = ["SWING_ACCURACY", "SWING_INTEGRATOR", "SwingResult", "SwingRunner", "SwingSummary",
           "run_swing", "swing_diagram"]
