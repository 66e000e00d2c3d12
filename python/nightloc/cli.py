"""The ``nightloc`` command line: one sub-command per module in :mod:`nightloc.commands`.

Errors in the user's input (bad files, bad values) end the command with a one-line message on
stderr and exit status 2, never a traceback; any other exception (a bug) ends it with a one-line
"internal error" and exit status 1. Set ``NIGHTLOC_DEBUG=1`` to see the traceback (and OpenCV's
own log messages, which are otherwise limited to errors).
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import io
import os
import sys
import warnings

from ._core import __version__
from .errors import NightlocWarning, cli_message

# Sub-command modules; each defines register(subparsers) which adds its parser and sets
# `run=<function(args) -> int>` as a default.
COMMAND_MODULES = (
    "nightloc.commands.demo",
    "nightloc.commands.info",
    "nightloc.commands.build_map",
    "nightloc.commands.route",
    "nightloc.commands.synth",
    "nightloc.commands.evaluate",
    "nightloc.commands.localize",
    "nightloc.commands.export_log",
    "nightloc.commands.camera_study",
    "nightloc.commands.node",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="nightloc",
        description="2D visual place recognition at night (Mount & Milford 2016) with a SIMD core.",
    )
    parser.add_argument("--version", action="version", version=f"nightloc {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    subparsers.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(subparsers)
    return parser


def error_message(error: BaseException) -> str:
    """One line describing ``error`` for the user.

    An error worded for the command line too (:func:`nightloc.errors.with_cli_words`) gives those
    words; operating-system errors read "<reason>: <path>" (not "[Errno 2] ..."), memory errors
    say so, and line breaks inside a message are folded so the output stays one line.
    """
    worded = cli_message(error)
    if worded is not None:
        message = worded
    elif isinstance(error, OSError) and error.strerror and error.filename is not None:
        message = f"{error.strerror}: {error.filename}"
        if error.filename2 is not None:
            message += f" -> {error.filename2}"
    elif isinstance(error, MemoryError):
        message = f"out of memory ({error})" if str(error) else "out of memory"
    else:
        message = str(error) or type(error).__name__
    return " ".join(message.split())


def _quiet_opencv() -> None:
    """Limits OpenCV's and FFmpeg's stderr logging to errors (decoder warnings would break the
    one-line error output); ``NIGHTLOC_DEBUG=1`` keeps them."""
    if os.environ.get("NIGHTLOC_DEBUG"):
        return
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET; read when FFmpeg starts
    try:
        import cv2

        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    except (ImportError, AttributeError):  # pragma: no cover - an OpenCV without the logging API
        pass


def _tolerant_streams() -> None:
    """Lets stdout and stderr print file names that are not valid UTF-8 (held by Python as lone
    surrogates) as escapes (``caf\\udce9``) instead of failing after the work is done."""
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, ValueError, io.UnsupportedOperation):
            stream.reconfigure(errors="backslashreplace")  # type: ignore[union-attr]  # a TextIOWrapper


def _closed_pipe() -> int:
    """The reader of stdout went away (``nightloc info | head -1``): stop quietly, like a
    command killed by SIGPIPE (exit status 141), without Python's "Broken pipe" complaints."""
    with contextlib.suppress(OSError, ValueError, AttributeError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())  # the interpreter's last flush then goes nowhere
        os.close(devnull)
    return EXIT_CLOSED_PIPE


def _print_warnings(command: str) -> None:
    """Within a ``warnings.catch_warnings()`` block: nightloc's own warnings
    (:class:`~nightloc.errors.NightlocWarning`) are printed each time, as one line on stderr
    (``nightloc localize: warning: ...``); other warnings as Python prints them."""
    warnings.simplefilter("always", NightlocWarning)
    shown = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if issubclass(category, NightlocWarning):
            print(f"nightloc {command}: warning: {' '.join(str(message).split())}", file=sys.stderr, flush=True)
        else:
            shown(message, category, filename, lineno, file, line)

    warnings.showwarning = show


#: Exit status when the reader of stdout closed the pipe (128 + SIGPIPE, as the shell reports).
EXIT_CLOSED_PIPE = 141


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``nightloc`` script; returns the exit status.

    0: success; 2: bad input (usage, values, files; one line on stderr); 1: internal error;
    130: interrupted; 141: the reader of stdout went away (a closed pipe; nothing is printed).
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    _quiet_opencv()
    _tolerant_streams()
    try:
        with warnings.catch_warnings():
            _print_warnings(args.command)
            status = int(args.run(args) or 0)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's last flush
        return status
    except BrokenPipeError:
        return _closed_pipe()
    except KeyboardInterrupt:
        print(f"nightloc {args.command}: interrupted", file=sys.stderr)
        return 130
    except (ValueError, TypeError, OSError, MemoryError) as error:
        if os.environ.get("NIGHTLOC_DEBUG"):
            raise
        print(f"nightloc {args.command}: error: {error_message(error)}", file=sys.stderr)
        return 2
    except Exception as error:  # a bug: still one line, the traceback on request
        if os.environ.get("NIGHTLOC_DEBUG"):
            raise
        print(
            f"nightloc {args.command}: internal error: {type(error).__name__}: {error_message(error)} "
            f"(run with NIGHTLOC_DEBUG=1 for the traceback, and please report it)",
            file=sys.stderr,
        )
        return 1


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
