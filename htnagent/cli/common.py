"""What every command shares, with the standard library only: the exit codes, the one-line
error, standard output closed or gone, and the guard around a command
(:func:`guarded`).  ``plan --hddl`` starts from here without the rest of the command line
(:mod:`.hddl_plan`), so nothing here may import rich, pydantic or anyio."""

from __future__ import annotations

import argparse
import errno
import io
import os
import sys
from collections.abc import Callable
from typing import TextIO

from htnagent.errors import HtnAgentError

PROG = "htnagent"

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_INVALID = 2
EXIT_INTERRUPTED = 130


def fail(message: str, code: int = EXIT_INVALID) -> int:
    print(f"{PROG}: error: {one_line(message)}", file=sys.stderr)
    return code


def one_line(text: str) -> str:
    return " ".join(text.split())


def is_terminal(stream: TextIO) -> bool:
    try:
        return stream.isatty()
    except (OSError, ValueError):  # closed, or no file behind it
        return False


def seconds(text: str) -> float:
    """``--timeout``: a positive, finite number of seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of seconds, got {text!r}") from None
    if not 0 < value < 1e9:  # also refuses nan and inf
        raise argparse.ArgumentTypeError(f"expected a positive number of seconds, got {text!r}")
    return value


class ClosedOutput(io.TextIOBase):
    """Standard output when the process was started without one (``>&-``)."""

    def write(self, text: str) -> int:
        raise OSError(errno.EBADF, "standard output is closed")


def reader_gone() -> None:
    """The reader of standard output went away (``| head``): what is still to be printed goes
    nowhere, quietly (Python would otherwise complain again when it flushes at exit)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # not a file descriptor (in-process): nothing to redirect
        pass


def output_failed(error: OSError) -> int:
    if isinstance(error, BrokenPipeError):
        # A command's answer was being printed, its work done: it stands.
        reader_gone()
        return EXIT_OK
    if error.filename is not None:
        return fail(f"{error.filename}: {error.strerror or error}")
    return fail(f"cannot write the output: {error.strerror or error}")


def first_error(group: BaseExceptionGroup[BaseException]) -> BaseException:
    """The error of ours inside task groups' exception groups (else the group)."""
    match, _ = group.split(HtnAgentError)
    if match is None:
        return group
    first: BaseException = match
    while isinstance(first, BaseExceptionGroup):
        first = first.exceptions[0]
    return first


def guarded(command: Callable[[], int], owns_process: bool) -> int:
    """Run ``command`` and return its exit code; an error of ours, no memory, Ctrl-C
    in-process or output that cannot be written each end as one line, never a traceback.

    ``owns_process``: the caller exits right after (``python -m htnagent``): the streams
    escape what they cannot show, a closed standard output is said when written to, and
    what is still buffered is flushed here, where a full disk can still be said.
    """
    if not owns_process:
        return _caught(command)
    # Names come from the user's files: a terminal that cannot show a character gets
    # an escape, never an encoding error.
    for stream in (sys.stdout, sys.stderr):
        if isinstance(stream, io.TextIOWrapper):
            stream.reconfigure(errors="backslashreplace")
    if sys.stdout is None:  # started with it closed: say so when output is written
        sys.stdout = ClosedOutput()
    code = _caught(command)
    try:
        sys.stdout.flush()  # what is still buffered: a full disk is said, not ignored
    except BrokenPipeError:
        reader_gone()
        return code  # the reader took what it wanted (| head): the command's result stands
    except OSError as e:
        failed = output_failed(e)
        return failed if code == EXIT_OK else code
    return code


def _caught(command: Callable[[], int]) -> int:
    try:
        return command()
    except HtnAgentError as e:
        return fail(str(e))
    except BaseExceptionGroup as group:  # an error of ours from inside a task group (serve, remote:)
        error = first_error(group)
        if isinstance(error, HtnAgentError):
            return fail(str(error))
        raise
    except MemoryError:
        return fail("out of memory: the input is too large for the memory this process may use")
    except KeyboardInterrupt:  # when called in-process, without the handlers of __main__
        print(f"{PROG}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except OSError as e:  # writing the output (files read or written are checked on the way)
        return output_failed(e)
