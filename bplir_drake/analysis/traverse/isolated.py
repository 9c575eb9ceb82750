"""Swings of a long traversal run in a worker process that is replaced
every so many swings, so that the traversal's memory stays bounded.

Every swing of a traversal has a structure of its own (its grip spacing,
incline and learnt landing aim), so it builds its own diagram, and the
Drake we run on (pydrake 1.51) does not free a diagram holding Python
systems: about 3 MB stay behind per swing (drake issue 23161), 6 GB over
a 1000-obstacle line.  :class:`IsolatedRunners` stands in for the
traversal's ``{1: SwingRunner, 2: SwingRunner}``: each swing runs in a
forked worker (the runners live there) and comes back pickled; the worker
is replaced after :data:`SWINGS_PER_WORKER` swings, taking what leaked
with it.  The results are the same as in the process itself (tested).

The worker is replaced here, between swings, by the main thread (not by
the pool's own ``maxtasksperchild``, whose replacements its handler thread
forks): a worker dies with the thread that forked it
(:func:`~bplir_drake.analysis.workers.quiet_worker`), and a worker forked
by the handler thread died as the pool ended, holding the pool's lock.
"""
from __future__ import annotations

import multiprocessing as mp
import os

from ..swing.swing_runner import SwingRunner
from ..workers import frozen_heap, quiet_worker
from ...systems.kernels import warm_up

#: swings a worker runs before a fresh one replaces it (about 3 MB each)
SWINGS_PER_WORKER = 50

_RUNNERS: dict = {}


def _run(gripper: int, params, kwargs: dict):
    """One swing in the worker, on its runner for ``gripper``."""
    return _RUNNERS.setdefault(gripper, SwingRunner()).run(params, **kwargs)


class _Proxy:
    """``runners[g]`` of :class:`IsolatedRunners`: ``run`` as SwingRunner's."""

    def __init__(self, owner: "IsolatedRunners", gripper: int):
        self.owner, self.gripper = owner, gripper

    def run(self, params, **kwargs):
        """:meth:`SwingRunner.run` in the worker process."""
        return self.owner.apply(_run, (self.gripper, params, kwargs))


class IsolatedRunners:
    """``{1: runner, 2: runner}`` whose swings run in a forked worker
    process, replaced every ``swings`` swings; :meth:`close` ends it."""

    def __init__(self, swings: int = SWINGS_PER_WORKER):
        self.swings = int(swings)
        self._pool = None
        self._ran = 0   # swings the present worker has run

    def apply(self, fn, args):
        """``fn(*args)`` in the worker; a fresh worker (forked by this thread)
        once the present one has run :attr:`swings` swings."""
        if self._pool is not None and self._ran >= self.swings:
            self.close()
        if self._pool is None:
            warm_up()   # the worker inherits the compiled kernels
            ctx = mp.get_context("fork")
            with frozen_heap():
                self._pool = ctx.Pool(1, initializer=quiet_worker, initargs=(os.getpid(),))
            self._ran = 0
        self._ran += 1
        return self._pool.apply(fn, args)

    def __getitem__(self, gripper: int) -> _Proxy:
        return _Proxy(self, gripper)

    def close(self) -> None:
        """End the worker (nothing is pending between swings)."""
        if self._pool is not None:
            self._pool.terminate()
            self._pool.join()
            self._pool = None
