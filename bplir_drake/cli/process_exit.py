"""How the ``bplir`` process ends: text that native code (SNOPT's Fortran,
a plug-in's C ``printf``) holds in its own buffers is written out while
the command's streams are still where the command put them, and the
console's process leaves without the interpreter's teardown, during which
Python no longer answers a signal (a second or so of module and library
destructors)."""
from __future__ import annotations

import ctypes
import os
import sys
from pathlib import Path


def loaded_gfortran() -> list[str]:
    """The paths of the Fortran runtimes this process has loaded (SNOPT's
    through Drake, another through numpy's linear algebra)."""
    try:
        maps = Path("/proc/self/maps").read_text()
    except OSError:
        return []
    paths = {line.split()[-1] for line in maps.splitlines() if "libgfortran" in line}
    return sorted(p for p in paths if p.startswith("/"))


def flush_native_output() -> None:
    """Write out what C's stdio and the Fortran runtime hold for their
    streams (to the descriptors those streams write to now)."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):
        pass
    for path in loaded_gfortran():
        try:
            ctypes.CDLL(path)._gfortran_flush_i4(None)   # NULL: every unit
        except (OSError, AttributeError):
            pass


def exit_now(code) -> None:
    """End the console's process with ``code``: threads joined and exit
    handlers run while the command's signal handlers still answer, then
    every stream flushed and the process gone at once."""
    import atexit
    import threading

    code = code if isinstance(code, int) else (0 if code is None else 1)
    # the command has said its last line: an exit handler's error that Python
    # would print as "Exception ignored in ..." (a half-started cluster's) is not
    sys.unraisablehook = lambda unraisable: None
    try:
        threading._shutdown()   # what the interpreter's own exit does first
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError, AttributeError):
                pass
        flush_native_output()
        os._exit(code)
