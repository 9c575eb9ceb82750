"""The package's forked workers never finalise the parent's garbage: a
study's pool (and the tests' forked commands) fork with the parent's heap
frozen (``analysis.workers.frozen_heap``)."""
import gc
import os
from pathlib import Path

from bplir_drake.analysis.montecarlo.executors import map_jobs

PARENT = os.getpid()


class _Garbage:
    """A cycle (only the collector frees it) whose finaliser records the
    process that ran it, as a Dask Client's waits for its event loop."""

    def __init__(self, where: Path):
        self.where, self.me = where, self

    def __del__(self):
        (self.where / ("parent" if os.getpid() == PARENT else f"child-{os.getpid()}")).touch()


def _collect(_):
    gc.collect()
    return os.getpid()


def test_a_pools_workers_leave_the_parents_garbage_alone(tmp_path):
    """Garbage left in the parent when a two-worker pool forks: each worker
    collects and finalises nothing of it; the parent's next collection
    does."""
    gc.disable()
    try:
        _Garbage(tmp_path)
        pids = set(map_jobs(_collect, [(k,) for k in range(4)], workers=2))
    finally:
        gc.enable()
    assert len(pids) == 2 and PARENT not in pids
    assert sorted(p.name for p in tmp_path.iterdir()) == []
    gc.collect()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["parent"]
