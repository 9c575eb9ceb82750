"""One brachiation swing: running it, comparing presets, planning it.

* :mod:`.run` -- :func:`~.run.run_swing`, :class:`~.run.SwingRunner` (one
  diagram for many samples), :func:`~.run.swing_diagram` (the diagram with
  its plan's gains), :class:`~.run.SwingResult`, log export;
* :mod:`.compare` -- the controller presets on one scenario;
* :mod:`.plan` -- trajectory optimisation of a swing and its tracking gains
  (Drake's finite-horizon LQR), cached on disk by :mod:`.plan_cache`;
* :mod:`.plots` -- plots and animation of a swing result.
"""
from .run import (SWING_ACCURACY, SWING_INTEGRATOR, SwingResult, SwingRunner, run_swing,
                  swing_diagram)

__all__ = ["SWING_ACCURACY", "SWING_INTEGRATOR", "SwingResult", "SwingRunner", "run_swing",
           "swing_diagram"]
