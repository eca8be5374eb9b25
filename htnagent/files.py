"""Reading a file a user names without trusting it: bytes to text.

:func:`read_text` is how htnagent reads every file a user names (scenarios and maps
through :mod:`htnagent.reading`, HDDL domains and problems through
:mod:`htnagent.hddl.reader`): a FIFO or a device instead of a file, a file too big, a
name the system refuses or bytes that are not text are one
:class:`~htnagent.errors.ScenarioError` naming the file and why.  Apart from the YAML
reader so that reading an HDDL file (``plan --hddl``) does not import PyYAML.
"""

from __future__ import annotations

import contextlib
import gc
import os
import stat
from collections.abc import Iterator
from pathlib import Path

from htnagent.errors import ScenarioError
from htnagent.limits import MAX_FILE_BYTES_ENV, max_file_bytes

__all__ = ["gc_paused", "read_text"]


# -- bytes ---------------------------------------------------------------------------

_KINDS = {
    stat.S_IFIFO: "a FIFO (named pipe)",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
}


def read_text(path: str | Path, what: str, max_bytes: int | None = None) -> str:
    """The text of a regular file of at most ``max_bytes`` bytes, decoded (UTF-8, or UTF-16/32 with a BOM).

    Anything else -- a directory, a FIFO, a device, a file too big, a name the
    system refuses -- is a ScenarioError naming the file and why.
    """
    file = str(path)
    limit = max_file_bytes(max_bytes)
    if not file:
        raise ScenarioError("''", "", f"no {what} file named '' (the file name is empty)")
    try:
        # Look before opening: opening a FIFO for reading blocks until a writer comes.
        info = os.stat(file)
        _check_kind(info, file, what, limit)
        # O_NONBLOCK all the same, in case the file was swapped for a FIFO meanwhile.
        flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
        fd = os.open(file, flags | getattr(os, "O_CLOEXEC", 0))
        try:
            _check_kind(os.fstat(fd), file, what, limit)
            raw = _read_at_most(fd, limit + 1)
        finally:
            os.close(fd)
    except FileNotFoundError:
        raise ScenarioError(file, "", f"no such file; expected a {what} file") from None
    except OSError as e:  # too long a name, a path through a file, no permission, I/O error, ...
        raise ScenarioError(file, "", f"cannot read the file: {e.strerror or e}") from None
    except ValueError:  # os functions refuse a name with a NUL character
        raise ScenarioError(file, "", "cannot read the file: its name holds a NUL character") from None
    if len(raw) > limit:
        raise _too_big(file, None, limit)
    return _decoded(raw, file, what)


def _check_kind(info: os.stat_result, file: str, what: str, limit: int) -> None:
    if stat.S_ISDIR(info.st_mode):
        raise ScenarioError(file, "", f"is a directory, not a {what} file")
    if not stat.S_ISREG(info.st_mode):
        kind = _KINDS.get(stat.S_IFMT(info.st_mode), "not a regular file")
        raise ScenarioError(file, "", f"is {kind}, not a {what} file; only regular files are read")
    if info.st_size > limit:
        raise _too_big(file, info.st_size, limit)


def _too_big(file: str, size: int | None, limit: int) -> ScenarioError:
    what = f"{size:,} bytes" if size is not None else "more than that when read"
    return ScenarioError(
        file, "", f"the file is too big ({what}; at most {limit:,} bytes are read, see {MAX_FILE_BYTES_ENV})"
    )


def _read_at_most(fd: int, n: int) -> bytes:
    chunks: list[bytes] = []
    left = n
    while left > 0:
        chunk = os.read(fd, min(left, 1 << 20))
        if not chunk:
            break
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


_BOMS = (
    (b"\xff\xfe\x00\x00", "utf-32-le"),
    (b"\x00\x00\xfe\xff", "utf-32-be"),
    (b"\xef\xbb\xbf", "utf-8"),
    (b"\xff\xfe", "utf-16-le"),
    (b"\xfe\xff", "utf-16-be"),
)


def _decoded(raw: bytes, file: str, what: str) -> str:
    """UTF-8 text, or another Unicode encoding its byte order mark announces (YAML allows them)."""
    encoding, start = "utf-8", 0
    for bom, name in _BOMS:
        if raw.startswith(bom):
            encoding, start = name, len(bom)
            break
    try:
        return raw[start:].decode(encoding)
    except UnicodeDecodeError as e:
        line = raw.count(b"\n", 0, start + e.start) + 1
        bad = raw[start + e.start : start + e.start + 1].hex()
        if encoding == "utf-8":
            reason = f"not UTF-8 text (byte 0x{bad} at byte {start + e.start}); expected a {what} file"
        else:
            reason = f"not valid {encoding.upper()} text (at byte {start + e.start})"
        raise ScenarioError(file, f"line {line}", reason) from None


@contextlib.contextmanager
def gc_paused() -> Iterator[None]:
    """No cyclic garbage collection while building big acyclic data (a map of 100,000 nodes).

    The collector would walk the million new containers again and again, for
    nothing: they form no cycles (recursive aliases are refused).  It runs
    again, as before, on leaving.
    """
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if collecting:
            gc.enable()
