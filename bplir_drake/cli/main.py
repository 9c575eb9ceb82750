"""Running the command line: parse, call the command, and turn every
failure into one line and an exit status (2 bad input, 1 a fault inside,
130/143/129 interrupted or terminated)."""
from __future__ import annotations

import contextlib
import functools
import os
import sys
import warnings

from ..analysis.control.qft_error import QftError
from ..analysis.identification.calibration_error import CalibrationError
from ..csvfile import LogError
from ..io import forget_stop, raise_stop, remove_unfinished
from ..params import ParameterError
from ..progress import command_started
from .common import _OUT, InputError, Terminated, _interrupt, _progress, _terminate
from .parser import build_parser
from .process_exit import exit_now, flush_native_output


def _note(message, category, filename, lineno, file=None, line=None) -> None:
    """A warning as one line on standard error (a renamed preset, ...)."""
    sys.stderr.write(f"bplir: note: {message}\n")


@functools.lru_cache(maxsize=1)
def _parser_of(builder):
    """The parser ``builder()`` gives, built once a process (parsing does
    not change it; a process that runs many command lines, as the tests'
    do, would otherwise rebuild its fourteen sub-parsers for each)."""
    return builder()


#: the longest error line's message (characters): a value echoed in it
#: (a 20 MB string from a file) is cut in its middle, keeping the line's
#: start, which names what is wrong, and its end, which says what is allowed
MAX_MESSAGE = 600


def shortened(text: str) -> str:
    """``text`` on one line, at most :data:`MAX_MESSAGE` characters and a
    note of how many were cut from its middle."""
    text = " ".join(text.split())
    if len(text) <= MAX_MESSAGE:
        return text
    head, tail = MAX_MESSAGE * 2 // 3, MAX_MESSAGE // 3
    return f"{text[:head]} ... ({len(text) - head - tail} characters cut) ... {text[-tail:]}"


def _run(args) -> int:
    """The command; a stop a solver turned into its own error (SNOPT through
    Drake wraps the ``Terminated`` its Python callback raised in a
    ``RuntimeError``) is raised again as the stop it was."""
    try:
        return args.func(args)
    except Exception:
        raise_stop()
        raise


@contextlib.contextmanager
def _stdout_for(json: bool):
    """The stream the command's result goes to.  Under ``--json`` standard
    output carries the one JSON object alone: everything else written to
    it -- a plug-in's prints, a solver's messages from C++, a worker
    process's output -- goes to standard error (file descriptor 1 is
    pointed there while the command runs, the result written through a
    copy of the original)."""
    if not json:
        yield sys.stdout
        return
    try:
        direct = sys.stdout.fileno() == 1
    except (AttributeError, OSError, ValueError):   # a stream without a descriptor
        direct = False
    if not direct:
        original = sys.stdout
        with contextlib.redirect_stdout(sys.stderr):
            yield original
        return
    sys.stdout.flush()
    out = os.fdopen(os.dup(1), "w", encoding=sys.stdout.encoding)
    os.dup2(2, 1)
    try:
        with contextlib.redirect_stdout(sys.stderr):
            yield out
    finally:
        out.flush()
        sys.stdout.flush()
        flush_native_output()   # a solver's buffered lines go to stderr, not after the JSON
        os.dup2(out.fileno(), 1)
        out.close()


#: the exit status of a command a signal stopped, once its line is written
_STOPPED: list = [None]

#: whether main() has finished its command and is tidying up
_FINISHING: list = [False]


def _after_the_command(signum, frame) -> None:
    """A signal while the finished command's process exits (the
    interpreter's teardown, a fraction of a second): one line and the
    signal's exit status, not a silent death by the signal; after a
    command a signal stopped (a process manager's second signal, ``timeout``
    passing its own on), the stop's status and no second line."""
    import signal

    if _STOPPED[0] is not None:
        os._exit(_STOPPED[0])
    name = signal.Signals(signum).name
    with contextlib.suppress(OSError, ValueError):
        sys.stdout.flush()
        sys.stderr.write(f"bplir: {name} after the command had finished; its outputs are "
                         "complete\n")
        sys.stderr.flush()
    os._exit(128 + signum)


def main(argv=None) -> int:
    """Run the command line; returns the exit status (2 with a one-line ``bplir: error:`` on bad
    input).  ``argv`` None: the console's command (``sys.argv``), whose process
    answers a signal with one line until it has exited."""
    _FINISHING[0] = False
    command_started()
    args = _parser_of(build_parser).parse_args(argv)
    command_started(_progress(args))
    _STOPPED[0] = None
    import signal

    shown = warnings.showwarning
    warnings.showwarning = _note
    previous = {}
    try:
        for sig, handler in ((signal.SIGTERM, _terminate), (signal.SIGHUP, _terminate),
                             (signal.SIGINT, _interrupt)):
            if signal.getsignal(sig) is not signal.SIG_IGN:   # nohup's, a background job's
                previous[sig] = signal.signal(sig, handler)
    except ValueError:   # not the main thread: leave the signals alone
        pass
    try:
        with _stdout_for(getattr(args, "json", False)) as out:
            _OUT[0] = out
            return _run(args)
    except (ParameterError, InputError, LogError, QftError, CalibrationError) as exc:
        sys.stderr.write(f"bplir: error: {shortened(str(exc))}\n")
        return 2
    except OSError as exc:   # a full disk, a vanished directory: the path and the reason
        if args.debug:
            raise
        where = f" {exc.filename}" if getattr(exc, "filename", None) else ""
        sys.stderr.write(f"bplir: error: {args.command}: cannot write or read{where}: "
                         f"{exc.strerror or exc}\n")
        return 1
    except KeyboardInterrupt as exc:
        code = 128 + exc.signum if isinstance(exc, Terminated) else 130
        what = (f"terminated by {signal.Signals(exc.signum).name}"
                if isinstance(exc, Terminated) else "interrupted")
        if args.command == "montecarlo":
            sys.stderr.write(f"bplir: {what}; the finished samples are kept in {args.out} "
                             "(the same command resumes the study)\n")
        else:  # every output is written atomically: none is left half-written
            sys.stderr.write(f"bplir: {what}; no output file was left half-written\n")
        _STOPPED[0] = code
        return code
    except Exception as exc:   # a fault inside: one line (the traceback with --debug)
        if args.debug:
            raise
        if "KeyboardInterrupt" in str(exc):   # Ctrl-C inside a C++ callback (SNOPT's)
            sys.stderr.write("bplir: interrupted; no output file was left half-written\n")
            _STOPPED[0] = 130
            return 130
        sys.stderr.write(f"bplir: error: {args.command} failed: {type(exc).__name__}: "
                         f"{shortened(str(exc)) or 'no message'}\n")
        return 1
    finally:
        _FINISHING[0] = True
        remove_unfinished()   # a signal between a temporary file and its with-block
        forget_stop()
        _OUT[0] = None
        warnings.showwarning = shown
        for sig, handler in previous.items():   # the console's process: until it has exited
            signal.signal(sig, _after_the_command if argv is None else handler)


def console() -> None:
    """The ``bplir`` console script and ``python -m bplir_drake.cli``:
    :func:`main` on ``sys.argv``, then the process ends with its status
    (:func:`~.process_exit.exit_now`: a signal up to its last moment gets
    its one line)."""
    import traceback

    try:
        code = main()
    except SystemExit as exc:   # argparse's usage errors and --help
        code = exc.code
        if isinstance(code, str):
            sys.stderr.write(code + "\n")
            code = 1
    except KeyboardInterrupt as exc:   # a signal in main's last steps, the command done
        code = _late_signal(exc)
    except BaseException:   # noqa: BLE001 - the process's top level (--debug)
        traceback.print_exc()
        code = 1
    exit_now(code)


def _late_signal(exc: KeyboardInterrupt) -> int:
    """The exit status (and line) of a signal that reached :func:`main`
    outside its command: after a stop, the stop's; once the command has
    finished, the line that its outputs are complete; before it began
    (while the command line was parsed), the stop's line."""
    import signal

    signum = exc.signum if isinstance(exc, Terminated) else signal.SIGINT
    if _STOPPED[0] is not None:
        return _STOPPED[0]
    if _FINISHING[0]:
        sys.stderr.write(f"bplir: {signal.Signals(signum).name} after the command had "
                         "finished; its outputs are complete\n")
    else:
        sys.stderr.write("bplir: interrupted before the command began; nothing was written\n")
    return 128 + signum
