"""Progress of long computations, on standard error.

Analysis functions take ``progress=False``; the command line passes
``True`` when standard error is a terminal and ``--json`` is off, so pipes,
logs and JSON consumers stay silent.  :func:`progress_bar` is a ``tqdm``
bar (or a do-nothing stand-in) that is also a context manager.
"""
from __future__ import annotations

import os
import sys


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


def progress_bar(enabled: bool, *, desc: str, unit: str, total: int | None = None):
    """A progress bar on standard error (``tqdm``; ``total=None``: a
    counter with a rate) when ``enabled``, else a silent stand-in."""
    if not enabled:
        return _Silent()
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
