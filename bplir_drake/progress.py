"""Progress of long computations, on standard error.

Analysis functions take ``progress=False``; the command line passes
``True`` when standard error is a terminal and ``--json`` is off, so pipes,
logs and JSON consumers stay silent.  :func:`progress_bar` is a ``tqdm``
bar (or a do-nothing stand-in) that is also a context manager.
"""
from __future__ import annotations

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

    return _Bar(total=total, desc=desc, unit=" " + unit, leave=False, file=sys.stderr)
