"""Whole traversals of a line: riding, swinging past its obstacles with
either gripper, retrying from hanging.

* :func:`~.line.load_line` -- a line's TOML (spans, inclines, obstacles) as
  a :class:`~.line.Line`;
* :func:`~.traversal.run_traverse` -- the traversal of a line by a robot,
  a :class:`~.traverse_result.TraverseResult` (its manoeuvres' rows, totals,
  motion log; ``plot()``, ``to_pandas()``, ``to_xarray()``).

::

    from bplir_drake.analysis.traverse import load_line, run_traverse
    from bplir_drake.params import BplirParams

    result = run_traverse(load_line("examples/line_flat.toml"), BplirParams(), seed=0)
    print(result.summary()["totals"]["outcome"], len(result.rows))   # passed, its rows
"""
from .line import Line, load_line
from .traversal import run_traverse
from .traverse_result import TraverseResult

__all__ = ["Line", "TraverseResult", "load_line", "run_traverse"]
