"""Files in and out, safely: UTF-8 text in (or a one-line error), outputs
written atomically (a temporary file in the same directory, then a rename),
strict JSON out (NaN and infinities become ``null``), output locations
checked before any work starts.

Nothing here knows the rest of the package: callers pass the exception
class their one-line errors use.
"""
from __future__ import annotations

import codecs
import contextlib
import json
import math
import os
import tempfile
import threading
import time
import zipfile
from pathlib import Path
from typing import Iterator
import numpy as np
from importlib.metadata import PackageNotFoundError, version

from .labelled import table_dataset
from .leftovers import sweep_unfinished

UTF8_BOM = b"\xef\xbb\xbf"


def read_text(path, what: str, error=ValueError) -> str:
    """The text of a UTF-8 file (a leading byte-order mark is accepted).

    A missing, unreadable, binary or UTF-16 file raises ``error`` with one
    line naming the file and the problem (:func:`text_lines`)."""
    return "".join(text_lines(path, what, error))


def text_lines(path, what: str, error) -> Iterator[str]:
    """The lines of a UTF-8 text file, decoded one at a time."""
    path = Path(path)
    try:
        f = open(path, "rb")
    except IsADirectoryError:
        raise error(f"{what} {path} is a directory, not a file") from None
    except OSError as exc:
        raise error(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    with f:
        try:
            head = f.read(4)
            if head[:2] in (b"\xff\xfe", b"\xfe\xff"):
                raise error(f"{what} {path} is UTF-16 text; save it as UTF-8")
            start = len(UTF8_BOM) if head.startswith(UTF8_BOM) else 0
            _check_text(f, start, f"{what} {path}", error)
            f.seek(start)
            for raw in f:
                yield raw.decode("utf-8")
        except OSError as exc:
            raise error(f"cannot read {what} {path}: {exc.strerror or exc}") from None


def _check_text(f, start: int, name: str, error, chunk: int = 1 << 20) -> None:
    """Check a whole file is UTF-8 text, a block at a time, before any of it
    is read as data (a binary file is named as one, wherever its bad byte)."""
    decoder = codecs.getincrementaldecoder("utf-8")()
    f.seek(start)
    offset = 0   # counted from the text's start, after a byte-order mark
    while True:
        block = f.read(chunk)
        if b"\x00" in block:
            raise error(f"{name} is a binary file, not UTF-8 text")
        try:
            decoder.decode(block, final=not block)
        except UnicodeDecodeError as exc:
            raise error(f"{name} is not UTF-8 text (invalid byte at offset "
                        f"{offset + exc.start})") from None
        if not block:
            return
        offset += len(block)


def _finite(obj):
    """``obj`` with every non-finite float replaced by None (recursively)."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj


def _plain(o):

    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    if isinstance(o, complex):
        return [o.real, o.imag]
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o)}")


def dumps_strict(obj, indent: int | None = 2) -> str:
    """JSON that strict parsers accept: NaN and +-Infinity become ``null``."""
    plain = json.loads(json.dumps(obj, default=_plain))  # numpy -> Python (NaN kept)
    return json.dumps(_finite(plain), indent=indent, allow_nan=False)


#: how deep in sections a signal must not cut (``depth``), and the raise a
#: signal asked for meanwhile (``pending``), run when the last one ends, and
#: the raise that has run (``raised``: :func:`raise_stop`)
_HELD = {"depth": 0, "pending": None, "raised": None}


def hold_or_run(action) -> None:
    """Run ``action`` (a signal handler's raise) now, or, inside a section
    an atomic write must finish (its temporary file made and named), when
    that section ends.  Blocking the signal is not enough: another thread
    (Drake's, a plotting library's) can take it, and Python then runs the
    handler in the main thread wherever that thread is."""
    if _HELD["depth"]:
        _HELD["pending"] = action
    else:
        _HELD["raised"] = action
        action()


def raise_stop() -> None:
    """Raise again the stop a signal's handler raised (:func:`hold_or_run`),
    if one has: a solver that calls back into Python (SNOPT through Drake)
    turns it into its own ``RuntimeError``, which a study must not keep as
    a sample's error while it goes on."""
    if _HELD["raised"] is not None:
        _HELD["raised"]()


def forget_stop() -> None:
    """The command has ended: a later one starts with no stop raised."""
    _HELD["raised"] = None


@contextlib.contextmanager
def _signals_held():
    """Hold Ctrl-C, SIGTERM and SIGHUP until the block ends (they are
    delivered then): the command line's handlers wait through
    :func:`hold_or_run`, and the main thread blocks them where the
    platform allows."""
    import signal

    _HELD["depth"] += 1
    held = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
    try:
        try:
            before = signal.pthread_sigmask(signal.SIG_BLOCK, held)
        except (AttributeError, ValueError, OSError):   # not POSIX
            before = None
        try:
            yield
        finally:
            if before is not None:
                signal.pthread_sigmask(signal.SIG_SETMASK, before)
    finally:
        _HELD["depth"] -= 1
        pending = _HELD["pending"]
        if pending is not None and not _HELD["depth"]:
            _HELD["pending"] = None
            _HELD["raised"] = pending
            pending()


# ------------------------------------------------------------ wall clock
class WallClockLimit(RuntimeError):
    """A simulation ran longer in wall-clock time than it was allowed
    (a hung plug-in, an integrator crawling)."""


#: what most likely ran past a wall-clock limit (the default of its message)
HUNG_PLUGIN = "a hung controller or plug-in?"
#: ... and what keeps a swing's plan solve within it
PLANNING = ("commission the robot first (bplir commission), so its plans are solved once, "
            "or raise the limit")


@contextlib.contextmanager
def wall_clock_limit(seconds: float | None, what: str = "the simulation",
                     hint: str = HUNG_PLUGIN):
    """Raise :class:`WallClockLimit` inside the block once it has run
    ``seconds`` of wall-clock time (SIGALRM; Python code -- a plug-in's
    calc, a Drake callback -- is stopped where it runs).  Outside the main
    thread, or with ``seconds`` None, nothing is limited."""
    import signal

    if not seconds or threading.current_thread() is not threading.main_thread():
        yield
        return
    outer = signal.getitimer(signal.ITIMER_REAL)[0]   # a limit around this one
    if 0.0 < outer <= seconds:   # the outer limit comes first: it stops the block
        yield
        return

    hit = []

    def on_alarm(signum, frame):
        hit.append(WallClockLimit(f"{what} ran past its wall-clock limit of {seconds:g} s "
                                  f"(scenario.wall_limit; {hint})"))
        raise hit[0]

    start = time.monotonic()
    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    except RuntimeError as exc:   # a solver calling back into Python wraps the limit in its
        if hit and not isinstance(exc, WallClockLimit):   # own error (SNOPT through Drake)
            raise hit[0] from None
        raise
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)
        if outer > 0.0:   # the outer limit goes on counting
            signal.setitimer(signal.ITIMER_REAL, max(outer - (time.monotonic() - start), 1e-3))


#: temporary files of atomic writes now in progress (see :func:`remove_unfinished`)
_UNFINISHED: set[str] = set()


def remove_unfinished() -> None:
    """Remove the temporary file of every atomic write still in progress.

    A signal can end a command at a moment when the write's own clean-up
    does not run (between making the file and entering the ``with`` block);
    the command line calls this when a signal or a fault ends a command."""
    for tmp in list(_UNFINISHED):
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        _UNFINISHED.discard(tmp)


@contextlib.contextmanager
def atomic_path(path):
    """Yield a temporary path beside ``path`` (same suffix) to write to; on
    success it is renamed onto ``path``, on failure removed.  A signal that
    arrives while the temporary file is made is held until it has a name
    to remove, so no temporary file outlives an interrupted write."""
    path = Path(path)
    tmp = None
    try:
        with _signals_held():
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.stem}-{os.getpid()}-",
                                       suffix=path.suffix)
            _UNFINISHED.add(tmp)
            os.close(fd)
            # mkstemp makes the file private (0600); outputs get the usual mode
            umask = os.umask(0)
            os.umask(umask)
        yield Path(tmp)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
        _UNFINISHED.discard(tmp)
    except BaseException as exc:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            _UNFINISHED.discard(tmp)
        if isinstance(exc, OSError) and exc.errno and exc.filename in (None, tmp, str(tmp)):
            # a full disk while writing: name the file the user asked for
            raise OSError(exc.errno, exc.strerror, str(path)) from exc
        raise


def write_npz(fh, arrays: dict, compressed: bool = False) -> None:
    """``arrays`` as NumPy's ``.npz`` into the open binary file ``fh``, as
    ``np.savez`` (``compressed``: ``np.savez_compressed``) would, but the
    same arrays give the same bytes: every member's time stamp is the zip
    format's first (1980-01-01), not the moment it was written."""
    how = zipfile.ZIP_DEFLATED if compressed else zipfile.ZIP_STORED
    with zipfile.ZipFile(fh, "w", compression=how, allowZip64=True) as z:
        for name, value in arrays.items():
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = how
            with z.open(info, "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(value), allow_pickle=False)


def write_text_atomic(path, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file and a rename."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def write_json_atomic(path, obj) -> Path:
    """``obj`` as strict JSON at ``path`` (atomic)."""
    return write_text_atomic(path, dumps_strict(obj) + "\n")


def check_output_dir(path, error=ValueError) -> Path:
    """Create ``path`` (a directory) if needed and prove it writable, before
    any work: an existing file, a read-only or pseudo filesystem raise
    ``error`` with one line."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise error(f"output directory {path} is an existing file; choose a directory")
    try:
        path.mkdir(parents=True, exist_ok=True)
        _probe(path)
    except OSError as exc:
        raise error(f"cannot write to output directory {path}: {exc.strerror or exc}") from None
    sweep_unfinished(path)
    return path


def _probe(directory: Path) -> None:
    """Create and remove a file in ``directory`` (OSError if that fails)."""
    fd, probe = tempfile.mkstemp(dir=directory, prefix=".bplir-probe-")
    os.close(fd)
    os.unlink(probe)


def check_output_file(path, error=ValueError) -> Path:
    """``path`` will be written as a file: its directory must exist and be
    writable, and ``path`` must not be a directory."""
    path = Path(path)
    if path.is_dir():
        raise error(f"output file {path} is a directory; give a file name")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise error(f"the directory of output file {path} does not exist: {parent}")
    try:
        _probe(parent)
    except OSError as exc:
        raise error(f"cannot write output file {path}: {exc.strerror or exc}") from None
    return path


def package_version() -> str:
    """The installed bplir-drake version (``"unknown"`` in a source tree
    without package metadata)."""

    try:
        return version("bplir-drake")
    except PackageNotFoundError:   # pragma: no cover - not installed
        return "unknown"


# ------------------------------------------------------------------ results
class Result:
    """What every result object offers (like python-control's response
    objects): a dataclass of computed data with ``summary()`` (JSON-ready
    numbers), ``to_dict()`` (what the command line writes), ``to_json()``
    (strict JSON), ``plot(axes=None)`` (draws, returns the figure) and
    ``to_pandas()`` (a ``pandas.DataFrame`` of its rows or time series,
    :meth:`table`; pandas is the ``pandas`` extra).  Mixin of the result
    dataclasses: ``to_dict`` from ``summary()``, ``to_json``,
    ``to_pandas``; subclasses define ``summary`` and ``plot`` (and
    ``table`` where they hold rows or time series)."""

    def summary(self) -> dict:  # pragma: no cover - defined by every result
        """The JSON-ready numbers of this result."""
        raise NotImplementedError

    def to_dict(self) -> dict:
        """The JSON-ready summary of this result."""
        return self.summary()

    def to_json(self) -> str:
        """:meth:`to_dict` as strict JSON text (NaN and infinity as null)."""
        return dumps_strict(self.to_dict())

    def plot(self, axes=None):  # pragma: no cover - defined by every result
        """Draw this result on ``axes`` (new figure when None); returns the figure."""
        raise NotImplementedError

    def table(self):
        """The result's rows (a list of dicts) or time series (a dict of
        columns); here one row of the summary's plain numbers and words."""
        return [{k: v for k, v in self.to_dict().items()
                 if isinstance(v, (int, float, str, bool, np.number, np.bool_)) or v is None}]

    def to_xarray(self):
        """:meth:`table` as an ``xarray.Dataset`` (time series over
        ``time``, rows over ``row``; xarray is the ``xarray`` extra)."""
        return table_dataset(self.table())

    def to_pandas(self):
        """:meth:`table` as a ``pandas.DataFrame``."""
        try:
            import pandas
        except ImportError:
            raise ImportError("to_pandas() needs pandas: pip install 'bplir-drake[pandas]'") \
                from None
        return pandas.DataFrame(self.table())


class Record(dict):
    """A row or a set of totals: the dict its file holds (JSON, CSV), whose
    fields also read and write as attributes (``row.outcome``); subclasses
    name what kind of row it is and document its fields."""

    def __getattr__(self, name: str):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(f"{type(self).__name__} has no field {name!r}") from None

    def __setattr__(self, name: str, value) -> None:
        self[name] = value

    def __reduce__(self):   # pickled as its class and its fields
        return (type(self), (dict(self),))


class DictResult(dict, Result):
    """A result that is also the plain dict it has always been (the summary
    of a study or of a benchmark, as its JSON file holds it): ``summary()``
    is that dict; ``plot`` and ``table`` come from the subclass."""

    def summary(self) -> dict:
        """The dict itself, as a plain dict."""
        return dict(self)
