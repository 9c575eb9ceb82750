"""What every command shares: loading parameters from options, checking option values, output locations, printing and saving."""
from __future__ import annotations

import argparse
import contextlib
import math
import sys
from pathlib import Path
from ..plotting import save_figure
from ..io import check_output_dir, dumps_strict, hold_or_run, write_json_atomic
from ..params import ParameterError


class InputError(ValueError):
    """Bad user input that is not a parameter (malformed log, bad option value)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, status 2
        sys.stderr.write(f"bplir: error: {message}\n")
        sys.exit(2)


def _floats(text: str, n: int, name: str) -> list[float]:
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"{name} = '{text}' must be {n} comma-separated numbers") from None
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise InputError(f"{name} = '{text}' must be {n} finite comma-separated numbers")
    return vals


def _load_params(args):
    from ..params import load_toml, preset

    if getattr(args, "config", None):
        if args.preset:  # the file's tables override the named preset
            from ..params import from_dict, read_toml

            params = from_dict(read_toml(args.config) | {"preset": args.preset},
                               base_dir=Path(args.config).parent)
        else:
            params = load_toml(args.config)
    else:
        params = preset(args.preset or "dissertation")
    return _with_settings(_with_hardware(params, args), args)


def _with_settings(params, args):
    """``params`` with every ``--set block.field=value`` (a TOML value;
    bare words are strings), read as one table of tables
    (:func:`~bplir_drake.params.from_dict`: a robot file read, and other
    links or another motor move the defaults that follow them unless also
    set)."""
    import tomllib

    from ..params import BLOCKS, from_dict, moved_field

    data: dict = {}
    for item in getattr(args, "set", None) or []:
        key, sep, text = item.partition("=")
        block, dot, name = key.strip().partition(".")
        if not (sep and dot and block and name):
            raise InputError(f"--set '{item}' must be block.field=value (e.g. plant.m2=1.6)")
        now = moved_field(block, name)
        if now != (block, name):
            import warnings

            warnings.warn(f"--set {block}.{name} is now --set {'.'.join(now)}", FutureWarning)
            block, name = now
        if block not in BLOCKS:
            raise ParameterError(f"--set {key}: unknown block '{block}'; allowed: "
                                 + ", ".join(BLOCKS))
        try:
            value = tomllib.loads(f"v = {text.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            value = text.strip()
        data.setdefault(block, {})[name] = value
    return from_dict(data, base=params, base_dir=Path.cwd()) if data else params


def _with_hardware(params, args):
    """``params`` with the ``--hardware`` options (comma-separated names)."""
    names = [n.strip() for n in (getattr(args, "hardware", None) or "").split(",") if n.strip()]
    from ..params import with_hardware

    return with_hardware(params, *names) if names else params


#: figure formats every drawing command writes (``--format``)
FIGURE_FORMATS = ("png", "pdf", "svg")


def _dpi_value(text: str) -> int:
    """``--dpi``'s value: a whole number in [30, 1200]."""
    try:
        dpi = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--dpi = '{text}' must be a whole number") from None
    if not 30 <= dpi <= 1200:
        raise argparse.ArgumentTypeError(f"--dpi = {dpi} is out of range; allowed [30, 1200]")
    return dpi


def _dpi(args) -> int:
    """``--dpi``, checked (raster resolution; vector formats keep it for their images)."""
    dpi = getattr(args, "dpi", None) or 150
    _in_range("--dpi", dpi, 30, 1200)
    return dpi


def _save(args, fig, path) -> Path:
    """Save ``fig`` at ``path`` with the suffix of ``--format`` and ``--dpi``."""
    fmt = getattr(args, "format", None) or "png"
    return save_figure(fig, Path(path).with_suffix("." + fmt), dpi=_dpi(args))


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, handled like Ctrl-C (temporary files removed,
    finished rows kept), with the exit status ``128 + signal``."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _terminate(signum, frame):
    """SIGTERM, SIGHUP: end the command (after an atomic write's critical
    section, :func:`~bplir_drake.io.hold_or_run`)."""
    def stop():
        raise Terminated(signum)
    hold_or_run(stop)


def _interrupt(signum, frame):
    """Ctrl-C: ``KeyboardInterrupt``, held as :func:`_terminate` holds."""
    def stop():
        raise KeyboardInterrupt
    hold_or_run(stop)


#: where the command's own output goes: standard output as ``main`` found it
#: (with ``--json`` everything else printed meanwhile -- a plug-in's
#: chatter -- goes to standard error, so standard output stays JSON)
_OUT = [None]


def _emit(obj, as_json: bool, text_lines) -> None:
    """Print ``obj`` as strict JSON (NaN and infinities as null) or the text."""
    out = _OUT[0] or sys.stdout
    if as_json:
        print(dumps_strict(obj), file=out)
    else:
        for line in text_lines:
            print(line, file=out)


def _write_json(path, obj) -> str:
    """Write ``obj`` as strict JSON, atomically; returns the path as text."""
    return str(write_json_atomic(path, obj))


def _progress(args):
    """How to show progress: bars (True) where standard error is a terminal
    and ``--json`` is off, else plain lines once a command runs long
    (``"lines"``, :mod:`~bplir_drake.progress`)."""
    return True if not getattr(args, "json", False) and sys.stderr.isatty() else "lines"


def _out_dir(path) -> Path:
    """The output directory, created and proven writable before any work."""
    if not str(path).strip():
        raise InputError("--out '' is empty; name an output directory")
    return check_output_dir(path, InputError)


def _in_range(name: str, value, lo: float, hi: float, *, lo_open: bool = False,
              hi_open: bool = False, unit: str = "") -> None:
    """Raise InputError unless ``lo <(=) value <(=) hi`` (finite)."""
    ok = isinstance(value, (int, float)) and math.isfinite(value) and \
        (value > lo if lo_open else value >= lo) and (value < hi if hi_open else value <= hi)
    if not ok:
        left, right = "(" if lo_open else "[", ")" if hi_open else "]"
        u = f" {unit}" if unit else ""

        def fmt(v):   # whole numbers in full (a seed's 4294967295, not 4.29497e+09)
            return str(v) if isinstance(v, int) and not isinstance(v, bool) else f"{v:g}"

        shown = fmt(value) if isinstance(value, (int, float)) else repr(value)
        raise InputError(f"{name} = {shown}{u} is out of range; allowed "
                         f"{left}{fmt(lo)}, {fmt(hi)}{right}{u}")


# ------------------------------------------------------------------ swing
def _with_path_mode(params, mode, law=None):
    """``params`` with ``path.mode`` set from ``--path-mode`` and
    ``landing.landing_law`` from ``--landing-law`` (None: kept)."""
    import dataclasses as dc

    from ..params import LANDING_LAWS, PATH_MODES

    if mode is not None:
        if mode not in PATH_MODES:
            raise InputError(f"--path-mode = '{mode}' is unknown; allowed: "
                             + ", ".join(PATH_MODES))
        params = params.with_(path=dc.replace(params.path, mode=mode))
    if law is not None:
        if law not in LANDING_LAWS:
            raise InputError(f"--landing-law = '{law}' is unknown; allowed: "
                             + ", ".join(LANDING_LAWS))
        params = params.with_(landing=dc.replace(params.landing, landing_law=law))
    return params


def _study_of(study_dir):
    """The study saved in a study directory (``StudyError`` when there is none)."""
    from ..analysis.montecarlo import STUDY_FILE, StudyError, load_study

    path = Path(study_dir) / STUDY_FILE
    if not path.exists():
        raise StudyError(f"{study_dir} is not a study directory (no {STUDY_FILE})")
    return load_study(path)


def _same(a, b) -> bool:
    """Recorded and re-run values agree (NaN equals NaN)."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


# ------------------------------------------------------------------ montecarlo
def _check_plugin(params) -> None:
    """Build a plugged-in controller and estimator once, so a broken one
    fails here with its one-line error instead of in every sample."""
    from ..diagrams.plugin import make_plugin

    for kind in ("controller", "estimator"):
        if getattr(params, kind).plugin:
            make_plugin(params, kind)


def _plugin_args_need_a_plugin(args) -> None:
    """``--controller-arg`` / ``--estimator-arg`` only with a plug-in named."""
    for kind in ("controller", "estimator"):
        if getattr(args, f"{kind}_arg", None) and not getattr(args, kind, None):
            raise InputError(f"--{kind}-arg needs --{kind} naming your plug-in "
                             f"(module:factory or a registered name)")


#: live views kept serving after their run (``--meshcat --wait``) until the
#: command has written its outputs and the user stops it
_LINGERING: list = []


@contextlib.contextmanager
def _live_view(params, what: str, pace: str, wait: bool = False):
    """A Meshcat view of the robot of ``params`` (``--meshcat``), its address
    said on standard error; the server stops when the block ends, or with
    ``wait`` (a run that ends well) once :func:`_serve_lingering` is stopped."""
    from ..analysis.live import LiveView

    view = LiveView(params.plant)
    try:
        sys.stderr.write(f"bplir: the {what} is shown at {view.url} (Meshcat, {pace})\n")
        sys.stderr.flush()
        yield view
    except BaseException:
        view.close()
        raise
    if wait:
        _LINGERING.append((what, view))
    else:
        view.close()


def _serve_lingering() -> None:
    """Keep the ``--wait`` live views serving, their outputs written, until
    Ctrl-C or SIGTERM, which then end the command as done (exit 0)."""
    import time

    from ..io import forget_stop

    if not _LINGERING:
        return
    try:
        for what, view in _LINGERING:
            sys.stderr.write(f"bplir: the {what} stays at {view.url}; its outputs are written; "
                             "Ctrl-C ends the command\n")
        sys.stderr.flush()
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:   # Ctrl-C, or SIGTERM (Terminated): the wait is over
        forget_stop()
    finally:
        for _, view in _LINGERING:
            view.close()
        _LINGERING.clear()
