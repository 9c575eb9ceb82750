"""Where samples run: a local process pool (forked workers) or a Dask
cluster; results are yielded as they finish."""
from __future__ import annotations

import contextlib
import logging
import os
import sys
from typing import Callable, Iterable

from .study import StudyError
from ...progress import progress_bar
from ..workers import frozen_heap, quiet_worker
from ...systems.kernels import warm_up

#: how long to try to reach a Dask scheduler before giving up (s)
SCHEDULER_TIMEOUT = 10.0
#: a local cluster's scheduler without a dashboard, its HTTP server on a
#: free port (it always starts one, on 8787 by default: a second cluster on
#: the machine warned that the port was taken)
NO_DASHBOARD = {"dashboard": False, "dashboard_address": ":0"}

# ------------------------------------------------------------ execution

def _pool_map(fn: Callable, args: list[tuple], workers: int) -> Iterable:
    """Yield fn(*a) as they finish, in a process pool (or inline).

    Workers are forked where the platform allows it (no re-import of the
    caller's script, no pydrake start-up per worker); each sample builds its
    own diagram, so no Drake object crosses a process boundary."""
    if workers <= 1:
        for a in args:
            yield fn(*a)
        return
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor, as_completed

    method = "fork" if "fork" in mp.get_all_start_methods() else "spawn"
    if method == "fork":
        warm_up()   # the workers inherit the compiled kernels
    ex = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context(method),
                             initializer=quiet_worker, initargs=(os.getpid(),))
    with frozen_heap():   # the first submit forks every worker
        futures = [ex.submit(fn, *a) for a in args]
    finished = False
    try:
        for fut in as_completed(futures):
            yield fut.result()
        finished = True
    finally:
        if finished:
            ex.shutdown(wait=True)
        else:  # interrupted: do not wait for the samples still running
            procs = list(getattr(ex, "_processes", {}).values())
            ex.shutdown(wait=False, cancel_futures=True)
            for proc in procs:
                proc.terminate()


@contextlib.contextmanager
def _silent_children():
    """Processes started inside the block (a local Dask cluster's nannies and
    workers) write their standard output and error to /dev/null: a worker's
    log lines and tracebacks when a signal ends the study, and a plug-in's
    prints, never reach the user's terminal or a ``--json`` result (a
    sample's error is its row's)."""
    for stream in (sys.stdout, sys.stderr):
        stream.flush()
    saved = [os.dup(1), os.dup(2)]
    null = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(null, 1)
        os.dup2(null, 2)
        yield
    finally:
        os.dup2(saved[0], 1)
        os.dup2(saved[1], 2)
        for fd in (*saved, null):
            os.close(fd)


@contextlib.contextmanager
def _quiet_dask_logs():
    """The client side of Dask says nothing below CRITICAL while a study runs
    (its warnings when a signal ends the study are not the user's)."""

    log = logging.getLogger("distributed")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        log.setLevel(level)


@contextlib.contextmanager
def _abandoned_if_stopped():
    """A local cluster a signal stops while it starts is closed here, its
    errors kept quiet, and forgotten: Dask's own exit handler would close
    it again and print the traceback of a cluster still starting."""
    try:
        yield
    except BaseException:
        from distributed.deploy.spec import SpecCluster

        for name in ("distributed", "asyncio", "tornado"):   # its nannies' failures to start,
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)   # logged as they end
        for cluster in list(SpecCluster._instances):
            if cluster.status.name != "closed":
                with contextlib.suppress(BaseException), _quiet_dask_logs():
                    cluster.close(timeout=5)
            SpecCluster._instances.discard(cluster)
        raise


def _dask_map(fn: Callable, args: list[tuple], scheduler: str | None, workers: int) -> Iterable:
    """Yield fn(*a) as they finish on a Dask cluster: an existing one at
    ``scheduler`` or a LocalCluster of ``workers`` single-threaded processes."""
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise StudyError("Dask is not installed; install the extra: pip install "
                         "'bplir-drake[dask]'") from None

    cluster = None
    try:
        if scheduler:
            try:
                client = Client(scheduler, timeout=f"{SCHEDULER_TIMEOUT:g}s")
            except Exception as exc:  # noqa: BLE001 - Dask raises many kinds here
                msg = " ".join(str(exc).split())[:200]
                raise StudyError(f"cannot reach the Dask scheduler at {scheduler}: {msg}; "
                                 "expected an address like tcp://HOST:8786") from None
        else:
            with _silent_children(), _abandoned_if_stopped():
                cluster = LocalCluster(n_workers=max(1, workers), threads_per_worker=1,
                                       processes=True, dashboard_address=None,
                                       silence_logs=logging.CRITICAL,
                                       scheduler_kwargs=NO_DASHBOARD)
            client = Client(cluster)
        with client, _quiet_dask_logs():
            futures = [client.submit(fn, *a, pure=False) for a in args]
            for fut in as_completed(futures):
                yield fut.result()
    finally:
        if cluster is not None:
            with _quiet_dask_logs():
                cluster.close()


def map_jobs(fn: Callable, args: list[tuple], *, workers: int = 0, dask: bool = False,
             scheduler: str | None = None, progress: bool = False,
             desc: str = "samples", unit: str = "swings") -> Iterable:
    """Run ``fn(*a)`` for every ``a``; yields results as they finish."""
    workers = workers or os.cpu_count() or 1
    if dask or scheduler:
        it = _dask_map(fn, args, scheduler, workers)
    else:
        it = _pool_map(fn, args, min(workers, max(1, len(args))))

    with progress_bar(progress, desc=desc, unit=unit, total=len(args)) as bar:
        for result in it:
            bar.update()
            yield result


