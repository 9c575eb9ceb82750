"""Temporary files a killed writer left behind: :func:`~bplir_drake.io.atomic_path`
writes ``.NAME-PID-XXXXXXXX.SUFFIX`` beside its output and renames it when
done; a ``kill -9`` or a power cut leaves it, and the next command into
that directory removes it (:func:`sweep_unfinished`)."""
from __future__ import annotations

import os
import re
import time
from pathlib import Path


#: a temporary file :func:`atomic_path` makes: ``.NAME-PID-XXXXXXXX.SUFFIX``
#: (and, from versions before the PID was in the name, ``.NAME-XXXXXXXX.SUFFIX``)
_TEMPORARY = re.compile(r"^\.(?P<name>.+?)-(?:(?P<pid>\d+)-)?[a-z0-9_]{8}(?P<suffix>\.[^.]*)?$")

#: a temporary file without its writer's PID is a killed writer's once it
#: is this old (s): every write of the package finishes within seconds
STALE_AFTER = 3600.0


def sweep_unfinished(directory: Path) -> list[Path]:
    """Remove the temporary files a killed writer (``kill -9``, a power
    cut) left in ``directory``: those whose writer's process is gone, and
    those without a PID that are :data:`STALE_AFTER` old.  Returns them."""
    gone = []
    try:
        entries = list(os.scandir(directory))
    except OSError:
        return gone
    now = time.time()
    for entry in entries:
        m = _TEMPORARY.match(entry.name)
        if m is None or not entry.is_file(follow_symlinks=False):
            continue
        pid = m.group("pid")
        try:
            stale = (not _alive(int(pid))) if pid else now - entry.stat().st_mtime > STALE_AFTER
            if stale:
                os.unlink(entry.path)
                gone.append(Path(entry.path))
        except OSError:
            continue
    return gone


def _alive(pid: int) -> bool:
    """Whether process ``pid`` exists (on this machine)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
