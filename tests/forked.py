"""``bplir`` in a process of its own, forked from the test's process: the
command line's ``main()`` with ``sys.argv``, the interpreter's signal
dispositions and warning filters, its own stdin, stdout and stderr, an
uncaught exception's traceback and exit 1 -- what ``python -m
bplir_drake.cli`` does once its imports are done, without the second of
imports (Drake, numba, the package) a fresh interpreter pays.  The tests of
the console script itself start real processes."""
from __future__ import annotations

import gc
import io
import os
import selectors
import signal
import subprocess
import sys
import time
import traceback
import warnings

#: the warning filters of a fresh interpreter started without -W (3.11)
FRESH_FILTERS = (("default", DeprecationWarning, "__main__"), ("ignore", DeprecationWarning, ""),
                 ("ignore", PendingDeprecationWarning, ""), ("ignore", ImportWarning, ""),
                 ("ignore", ResourceWarning, ""))


def bplir_forked(*argv, env=None, preexec=None, before=None, timeout=180.0):
    """Run ``bplir ARGV`` in a forked child: (exit status, stdout, stderr),
    the status negative for a signal (as :mod:`subprocess` gives it).
    ``env``: variables set in the child's environment; ``preexec()`` runs
    in the child first (resource limits); ``before()`` after the child is
    set up, before ``main()`` (a stand-in patched into the package); a
    child still running after ``timeout`` s is killed (status -9)."""
    proc = start_forked(*argv, env=env, preexec=preexec, before=before)
    out, err = proc.communicate(timeout)
    return proc.returncode, out, err


def start_forked(*argv, env=None, preexec=None, before=None, new_session=False,
                 stdout=True, stderr=True) -> "Forked":
    """Start ``bplir ARGV`` in a forked child, as :func:`bplir_forked` does,
    and return at once; ``new_session``: the child leads a session and
    process group of its own (a terminal's Ctrl-C reaches its group);
    ``stdout``, ``stderr``: True a pipe, False /dev/null, or a file
    descriptor of this process's (a terminal's)."""
    main = _ready()
    pipes = [os.pipe() if want is True else None if want is False else (None, want)
             for want in (stdout, stderr)]
    sys.stdout.flush()
    sys.stderr.flush()
    gc.freeze()   # the child never finalises this process's garbage (a Dask Client's
    pid = os.fork()   # __del__ would wait 20 s for an event loop the fork did not copy)
    if pid:
        gc.unfreeze()
    if pid == 0:   # the child: never returns
        _child([str(a) for a in argv], env, preexec, before, main, pipes, new_session)
    for pipe in pipes:
        if pipe is not None and pipe[0] is not None:
            os.close(pipe[1])
    return Forked(pid, [pipe[0] if pipe is not None else None for pipe in pipes])


class Forked:
    """A running forked ``bplir``: the parts of ``subprocess.Popen`` the
    tests use (``pid``, ``returncode``, ``poll``, ``wait``, ``send_signal``,
    ``kill``, ``communicate``)."""

    def __init__(self, pid: int, fds):
        self.pid, self.returncode, self._fds = pid, None, fds

    def poll(self):
        if self.returncode is None:
            pid, status = os.waitpid(self.pid, os.WNOHANG)
            if pid:
                self.returncode = os.waitstatus_to_exitcode(status)
        return self.returncode

    def wait(self, timeout=None):
        end = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if end is not None and time.monotonic() > end:
                raise subprocess.TimeoutExpired(f"bplir (pid {self.pid})", timeout)
            time.sleep(0.01)
        return self.returncode

    def send_signal(self, sig):
        if self.poll() is None:
            os.kill(self.pid, sig)

    def kill(self):
        self.send_signal(signal.SIGKILL)

    def communicate(self, timeout=None):
        """(stdout, stderr) once the child has closed them and ended (killed
        after ``timeout`` s)."""
        out, err = _read_all(self._fds, self.pid, 1e9 if timeout is None else timeout)
        self._fds = [None, None]
        self.wait()
        return out, err


def _ready():
    """The command line's ``main``, with the modules its commands import and
    the compiled kernels loaded in this process (once), for every child."""
    if not _MAIN:
        import importlib

        from bplir_drake.cli import main
        from bplir_drake.systems.kernels import warm_up

        for name in READY:
            importlib.import_module(name)
        warm_up()
        _MAIN.append(main)
    return _MAIN[0]


_MAIN = []


#: the modules the simulating commands import, loaded before the first fork
READY = ("bplir_drake.analysis.swing.swing_runner", "bplir_drake.analysis.swing.swing_plots",
         "bplir_drake.analysis.montecarlo", "bplir_drake.analysis.traverse.traversal",
         "bplir_drake.analysis.traverse.traverse_plots")


def _child(argv, env, preexec, before, main, pipes, new_session):
    code = 1
    try:
        if new_session:
            os.setsid()
        os.dup2(os.open(os.devnull, os.O_RDONLY), 0)
        for fd, pipe in ((1, pipes[0]), (2, pipes[1])):
            os.dup2(pipe[1] if pipe is not None else os.open(os.devnull, os.O_WRONLY), fd)
        for pipe in pipes:
            if pipe is not None and pipe[0] is not None:
                os.close(pipe[0])
                os.close(pipe[1])
        sys.stdin = io.TextIOWrapper(io.FileIO(0, "r", closefd=False))
        sys.stdout = io.TextIOWrapper(io.FileIO(1, "w", closefd=False), line_buffering=True)
        sys.stderr = io.TextIOWrapper(io.FileIO(2, "w", closefd=False), line_buffering=True)
        signal.signal(signal.SIGINT, signal.default_int_handler)
        for sig in (signal.SIGTERM, signal.SIGHUP, signal.SIGALRM, signal.SIGXFSZ):
            signal.signal(sig, signal.SIG_DFL)
        warnings.resetwarnings()
        for action, category, module in reversed(FRESH_FILTERS):
            warnings.filterwarnings(action, category=category, module=module)
        os.environ.update({k: str(v) for k, v in (env or {}).items()})
        sys.argv = ["bplir", *argv]
        if preexec is not None:
            preexec()
        if before is not None:
            before()
        code = main()
    except SystemExit as exc:
        code = exc.code
        if isinstance(code, str):
            sys.stderr.write(code + "\n")
            code = 1
    except BaseException:   # noqa: BLE001 - the interpreter's top level
        traceback.print_exc()
        code = 1
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:   # noqa: BLE001 - a full pipe or disk: the status stands
                pass
        os._exit(code if isinstance(code, int) else 0)


def _read_all(fds, pid, timeout):
    """Everything the child writes to ``fds`` (stdout, stderr; None: not a
    pipe) until they close, killing it after ``timeout`` s."""
    chunks = {fd: [] for fd in fds if fd is not None}
    sel = selectors.DefaultSelector()
    for fd in chunks:
        sel.register(fd, selectors.EVENT_READ)
    end = time.monotonic() + timeout
    while sel.get_map():
        left = end - time.monotonic()
        if left <= 0:
            os.kill(pid, signal.SIGKILL)
            end = float("inf")
            continue
        for key, _ in sel.select(min(left, 1.0)):
            data = os.read(key.fd, 65536)
            if data:
                chunks[key.fd].append(data)
            else:
                sel.unregister(key.fd)
                os.close(key.fd)
    return tuple(b"".join(chunks[fd]).decode(errors="replace") if fd is not None else None
                 for fd in fds)
