"""Reading a text input file (`.wl`, `.ctl`) so that every failure is one ``path:line: message``.

:func:`read_text` turns what ``open``/``read``/decoding can raise (no such file, a
directory, no permission, a binary or non-UTF-8 file) into a
:class:`~cpgjax.errors.DescriptionError` that names the file, the line (0 where there is
none) and how to fix it, so that the command line prints one line instead of a traceback.
"""

from __future__ import annotations

import difflib
import os

from cpgjax.errors import DescriptionError

__all__ = ["MissingFileError", "read_text"]

MAX_BYTES = 64 * 1024 * 1024  # a description or controller is a few kB; this is not one


class MissingFileError(DescriptionError, FileNotFoundError):
    """A DescriptionError for a file that does not exist (also a ``FileNotFoundError``)."""


def _siblings(folder: str, ext: str) -> list[str]:
    try:
        return sorted(f for f in os.listdir(folder or ".") if f.endswith(ext)
                      and os.path.isfile(os.path.join(folder or ".", f)))
    except OSError:
        return []


def read_text(path: str | os.PathLike[str], ext: str) -> tuple[str, str]:
    """``(path, text)`` of a UTF-8 text file whose name should end with ``ext`` (``".wl"``).

    Raises :class:`DescriptionError` ``path:line: message`` (``MissingFileError`` when it
    does not exist).
    """
    p = os.fspath(path)
    kind = f"a {ext} file"
    if os.path.isdir(p):
        files = _siblings(p, ext)
        hint = (f"; name one of its {ext} files, e.g. {os.path.join(p, files[0])} (there: {', '.join(files)})"
                if files else f"; it holds no {ext} file")
        raise DescriptionError(p, 0, f"is a directory, not {kind}{hint}")
    try:
        with open(p, "rb") as f:
            data = f.read(MAX_BYTES + 1)
    except FileNotFoundError:
        folder, name = os.path.split(p)
        if folder and not os.path.isdir(folder):
            hint = f"; the directory '{folder}' does not exist either"
        else:
            close = difflib.get_close_matches(name, _siblings(folder, ext), n=1, cutoff=0.6)
            hint = f" (did you mean '{os.path.join(folder, close[0])}'?)" if close else ""
        raise MissingFileError(p, 0, f"no such file{hint}") from None
    except PermissionError:
        raise DescriptionError(p, 0, "cannot be read: permission denied") from None
    except OSError as e:
        raise DescriptionError(p, 0, f"cannot be read: {e.strerror or e}") from None
    if len(data) > MAX_BYTES:
        raise DescriptionError(p, 0, f"is larger than {MAX_BYTES // 2**20} MiB: not {kind} (plain text); "
                                     "is this the right file?")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as e:
        line = data.count(b"\n", 0, e.start) + 1
        raise DescriptionError(p, line, f"not a UTF-8 text file (byte 0x{data[e.start]:02x}: {e.reason}); "
                                        f"{kind} is plain text: is this the right file?") from None
    if "\x00" in text:
        line = text.count("\n", 0, text.index("\x00")) + 1
        raise DescriptionError(p, line, f"not a text file (it holds NUL bytes); {kind} is plain text: is "
                                        "this the right file?")
    # universal newlines, as ``open(p, encoding="utf-8")`` reads
    return p, text.replace("\r\n", "\n").replace("\r", "\n")
