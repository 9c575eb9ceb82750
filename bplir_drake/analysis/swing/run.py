"""The 0.1.0 import path of a swing's run, kept for code written against
it: :func:`run_swing`, :class:`SwingResult` and :func:`motor_summary` live
in :mod:`.swing_runner`, :func:`write_log_csv` in :mod:`.logs`."""
from .logs import write_log_csv
from .swing_runner import SwingResult, motor_summary, run_swing

__all__ = ["run_swing", "SwingResult", "write_log_csv", "motor_summary"]
