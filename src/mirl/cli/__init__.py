"""The ``mirl`` command line (top layer): parses arguments, runs a sub-command, and turns every
user error into one line on stderr naming the sub-command (``mirl run: error: …``) with exit
code 2. It may import every other stage."""

from __future__ import annotations

import os
import sys
from collections.abc import Sequence

from mirl._blas import one_blas_thread
from mirl.cli.checks import UsageError
from mirl.cli.commands import COMMANDS
from mirl.cli.flags import in_flags
from mirl.cli.parser import build_parser

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``mirl`` command: parse ``argv``, run its sub-command and answer a user's error
    with one line on stderr.

    Parameters
    ----------
    argv : sequence of str, optional
        The arguments after ``mirl`` (``sys.argv[1:]`` if None).

    Returns
    -------
    int
        The exit code: 0 on success, 2 on a user's error (one line naming the sub-command and
        the problem, no traceback), 130 when interrupted, 141 when the reader of its output
        left (``mirl run | head``).
    """
    one_blas_thread()  # before any sub-command loads numpy (docs/design.md, "BLAS threads")
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    prog = f"mirl {args.command}"
    try:
        return COMMANDS[args.command](args)
    except BrokenPipeError:
        return _reader_left()
    except MemoryError:  # the estimate checked before the work was too low for this machine
        print(
            f"{prog}: error: out of memory; the estimate checked at the start was too low for "
            "this map here: try a larger cell size or a smaller --max-memory share for others",
            file=sys.stderr,
        )
        return 2
    except Exception as exc:
        if not isinstance(exc, (ValueError, OSError, UsageError, *_sqlite_errors())):
            raise
        # domain errors (MapError, ScenarioError, TrajectoryError, ...) already name the file
        msg = str(exc).splitlines()[0] if str(exc) else exc.__class__.__name__
        print(f"{prog}: error: {in_flags(msg)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("mirl: interrupted", file=sys.stderr)
        return 130


def _sqlite_errors() -> tuple[type[Exception], ...]:
    """sqlite3's errors, if a sub-command loaded it (the run store): only then can one be raised,
    so `mirl run` does not import it."""
    sqlite3 = sys.modules.get("sqlite3")
    return (sqlite3.Error,) if sqlite3 is not None else ()


def _reader_left() -> int:
    """``mirl run | head``: the reader closed the pipe. Not an error of the user's input, so no
    message; stdout is pointed at /dev/null so that the interpreter's last flush does not fail
    again, and the exit code is the shell's for a writer stopped by SIGPIPE (128 + 13)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    return 141
