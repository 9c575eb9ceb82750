"""The worker processes the package forks (a study's pool, a long
traversal's swing runner): they end with their parent and leave signals
to it, so a Ctrl-C, a SIGTERM or a ``kill -9`` of the command prints no
worker's traceback and leaves no worker running; and they never
finalise the parent's garbage (:func:`frozen_heap`)."""
from __future__ import annotations

import contextlib
import gc
import os


@contextlib.contextmanager
def frozen_heap():
    """Fork workers inside this block: the parent's objects are moved out of
    the collector's reach (``gc.freeze``) while it forks, so a worker's
    collections never finalise what the parent left as garbage -- a Dask
    ``Client`` whose ``__del__`` waits about 20 s for an event loop thread
    the fork did not copy, say.  The parent's collector takes them back
    after the block."""
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def quiet_worker(parent: int) -> None:
    """A forked worker's initializer: ask Linux to end this worker when its
    parent dies (``PR_SET_PDEATHSIG``), so a ``kill -9`` of the command
    leaves nothing running; elsewhere nothing happens.  If the parent died
    before the request took effect, exit now.  The parent's signal handlers
    are undone: the parent alone answers Ctrl-C (a terminal sends it to the
    whole group) and ends its workers with SIGTERM, which they obey
    silently."""
    import ctypes
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, int(signal.SIGKILL), 0, 0, 0)   # 1: PR_SET_PDEATHSIG
    except (OSError, AttributeError):   # not Linux
        return
    if os.getppid() != parent:
        os._exit(1)
