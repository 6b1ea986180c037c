"""A quiet exit when the reader of standard output goes away (``... | head``).

A closed pipe is not an error of the program writing into it: like ``cat`` or
``grep``, print nothing more and exit with status 141 (128 + SIGPIPE, what a shell
reports for a program stopped by the signal).
"""

from __future__ import annotations

import os
import sys
from functools import wraps
from typing import Any, Callable

import click

from esair_min.errors import EsairError

CLOSED_PIPE_STATUS = 141


class PipeClosed(BaseException):
    """Standard output's reader went away (a BaseException: no ``except OSError`` or
    ``except Exception`` on the way may mistake it for an error to report)."""


class _Guarded:
    """A text stream whose writes raise :class:`PipeClosed` instead of BrokenPipeError."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            raise PipeClosed() from None

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            raise PipeClosed() from None

    def __getattr__(self, name: str):
        return getattr(self._stream, name)


def silence_stdout() -> None:
    """Point standard output at /dev/null so that the interpreter's final flush of
    what is still buffered cannot fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass


def quiet_on_closed_pipe(main: Callable[[], int | None]) -> int:
    """Run ``main`` with standard output guarded; its status, or 141 when the pipe
    closed."""
    real = sys.stdout
    sys.stdout = _Guarded(real)
    try:
        return main() or 0
    except (PipeClosed, BrokenPipeError):
        sys.stdout = real
        silence_stdout()
        return CLOSED_PIPE_STATUS
    finally:
        sys.stdout = real


def friendly(fn: Callable[..., Any]) -> Callable[..., Any]:
    """A CLI command's wrapper, the one place errors become exit codes (``esair`` and
    ``esair std`` alike): an EsairError is one ``error: ...`` line on stderr (a robot's
    several board-file errors one line each) and exit status 1; a closed standard output
    (``esair ... | head``) a quiet exit (141)."""

    @wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except EsairError as exc:
            for line in exc.lines():
                click.echo(f"error: {line}", err=True)
            sys.exit(1)
        except BrokenPipeError:
            silence_stdout()
            sys.exit(CLOSED_PIPE_STATUS)

    return wrapper
