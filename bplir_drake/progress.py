"""Progress of long computations, on standard error.

Analysis functions take ``progress=False``; the command line passes
``True`` when standard error is a terminal and ``--json`` is off (a
``tqdm`` bar), and ``"lines"`` otherwise: a log, a pipe or a JSON
consumer's terminal gets plain ``bplir: progress:`` lines, none in a
command's first :data:`QUIET_FOR` seconds (a short command says nothing
but its result) and then one whenever a phase begins or ends and at least
every :data:`EVERY` seconds while one runs, so a long solve never looks
hung.  :func:`progress_bar` is the bar, the line reporter or a
do-nothing stand-in, each also a context manager.
"""
from __future__ import annotations

import os
import sys
import threading
import time

#: a command's seconds of silence before its first progress line
QUIET_FOR = 20.0

#: the longest time between two progress lines while a phase runs (s)
EVERY = 20.0

#: when this process's first reporter began (the command's start, near enough)
_STARTED: list = [None]

#: the reporters open now, innermost last: only the innermost says it runs on
_OPEN: list = []


class _Silent:
    """The stand-in when progress is off: every call does nothing."""

    def update(self, n: int = 1) -> None:
        """Count ``n`` more steps (ignored)."""

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        """Show ``text`` beside the bar (ignored)."""

    def close(self) -> None:
        """End the bar (nothing to end)."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None


class _Lines:
    """Progress as plain lines on standard error (the ``"lines"`` mode)."""

    def __init__(self, desc: str, unit: str, total: int | None):
        self.desc, self.unit, self.total, self.n, self.note = desc, unit, total, 0, ""
        if _STARTED[0] is None:
            _STARTED[0] = time.monotonic()
        self.t0 = time.monotonic()
        self.last = self.t0
        self._said_begin = False
        self._done = threading.Event()
        _OPEN.append(self)
        self._say("begins")
        self._beat = threading.Thread(target=self._run_on, daemon=True)
        self._beat.start()

    def _count(self) -> str:
        of = f"/{self.total}" if self.total is not None else ""
        return f"{self.n}{of} {self.unit}"

    def _say(self, what: str) -> None:
        """One line, once the command's quiet start is over."""
        now = time.monotonic()
        if now - _STARTED[0] < _quiet_for():
            return
        if what != "begins" and not self._said_begin:
            what = f"{what} (began {now - self.t0:.0f} s ago)"
        self._said_begin = True
        note = f"; {self.note}" if self.note else ""
        try:
            sys.stderr.write(f"bplir: progress: {self.desc}: {what}, {self._count()}, "
                             f"{now - self.t0:.0f} s{note}\n")
            sys.stderr.flush()
        except (OSError, ValueError):
            pass
        self.last = now

    def _run_on(self) -> None:
        every = _every()
        while not self._done.wait(min(every, 1.0)):
            if _OPEN and _OPEN[-1] is self and time.monotonic() - self.last >= every:
                self._say("running")

    def update(self, n: int = 1) -> None:
        """Count ``n`` more steps."""
        self.n += n

    def set_postfix_str(self, text: str, refresh: bool = True) -> None:
        """Say ``text`` in the following lines."""
        self.note = text

    def close(self) -> None:
        """The phase ends: its last line (once lines are being said)."""
        if self._done.is_set():
            return
        self._done.set()
        if self in _OPEN:
            _OPEN.remove(self)
        self._say("done")

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


#: how a computation that is not handed a ``progress`` shows it (a plan
#: solved deep inside a swing): the command line sets its own mode here
_AMBIENT: list = [False]


def command_started(mode=False) -> None:
    """A command begins now, showing progress by ``mode`` (False, True or
    ``"lines"``) where a computation is not told otherwise: its first
    :data:`QUIET_FOR` seconds are quiet."""
    _STARTED[0] = time.monotonic()
    _AMBIENT[0] = mode


def ambient():
    """``"lines"`` while a command shows progress as lines, else False: a
    computation nobody handed ``progress`` says it runs long in a log, but
    draws no bar of its own on a terminal (a pool's workers would draw
    theirs over each other)."""
    return "lines" if _AMBIENT[0] == "lines" else False


def _quiet_for() -> float:
    """:data:`QUIET_FOR`, or ``$BPLIR_PROGRESS_QUIET`` (s) where set (tests)."""
    return float(os.environ.get("BPLIR_PROGRESS_QUIET", QUIET_FOR))


def _every() -> float:
    """:data:`EVERY`, or ``$BPLIR_PROGRESS_EVERY`` (s) where set (tests)."""
    return float(os.environ.get("BPLIR_PROGRESS_EVERY", EVERY))


def progress_bar(enabled, *, desc: str, unit: str, total: int | None = None):
    """A progress bar on standard error (``tqdm``; ``total=None``: a
    counter with a rate) when ``enabled`` is true, plain lines when it is
    ``"lines"``, else a silent stand-in."""
    if not enabled:
        return _Silent()
    if enabled == "lines":
        return _Lines(desc, unit, total)
    from tqdm import tqdm

    class _Bar(tqdm):
        """tqdm throttles redraws (``mininterval``): draw the final count
        before the bar is cleared, so the last count shown is the count
        the result reports."""

        def close(self) -> None:
            if not self.disable:
                self.refresh()
            super().close()

    columns, lines = _terminal_size()
    return _Bar(total=total, desc=desc, unit=" " + unit, leave=False, file=sys.stderr,
                ncols=None if columns else FALLBACK_SIZE[0],
                nrows=None if lines else FALLBACK_SIZE[1])


#: the size (columns, lines) a bar assumes on a terminal that reports none (a
#: serial console, a pseudo-terminal whose size was never set: 0 x 0), where
#: tqdm would otherwise draw nothing
FALLBACK_SIZE = (80, 24)


def _terminal_size() -> tuple[int, int]:
    """(columns, lines) standard error's terminal reports (0 where it reports none)."""
    try:
        size = os.get_terminal_size(sys.stderr.fileno())
    except (OSError, ValueError, AttributeError):
        return 0, 0
    return size.columns, size.lines
