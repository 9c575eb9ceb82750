"""A periodic logger with a phase offset, for discrete signals.

Drake's ``VectorLogSink`` publishes at ``k*period`` *before* the discrete
updates of that instant, so a sampled signal would be logged one period
late.  :class:`SampleLogger` publishes at ``k*period + offset``, after the
updates of tick ``k``, and records the sample under its tick time
``k*period``.
"""
from __future__ import annotations

import numpy as np
from pydrake.systems.framework import LeafSystem


class SampleLogger(LeafSystem):
    def __init__(self, size: int, period: float, offset: float):
        super().__init__()
        self._period, self._offset = period, offset
        self.DeclareVectorInputPort("u", size)
        self.DeclarePeriodicPublishEvent(period, offset, self._record)
        self._t: list[float] = []
        self._rows: list[np.ndarray] = []

    def _record(self, context):
        k = round((context.get_time() - self._offset) / self._period)
        self._t.append(k * self._period)
        self._rows.append(np.array(self.get_input_port(0).Eval(context), dtype=float))

    def arrays(self):
        """(t, data) with data of shape (N, size)."""
        if not self._rows:
            return np.zeros(0), np.zeros((0, self.get_input_port(0).size()))
        return np.array(self._t), np.vstack(self._rows)
