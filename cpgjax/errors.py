"""The package's error types (the lowest layer: every other module may import it).

``cpgjax.cli`` maps each of them to one line on stderr and exit code 2 (bad input) without a
traceback; a run is never left half-written by any of them.
"""

from __future__ import annotations


class CpgjaxError(Exception):
    """Base of cpgjax's own errors: a message meant for the user, with the file or option it concerns."""


class DescriptionError(CpgjaxError, ValueError):
    """A problem in a description or control file, reported as ``path:line: message`` (``path: message`` when
    it concerns the whole file, ``line`` 0: it is missing, a folder, not text)."""

    def __init__(self, path: str, line: int, message: str):
        self.path, self.line, self.message = path, line, message
        super().__init__(f"{path}:{line}: {message}" if line else f"{path}: {message}")


class ResultsError(CpgjaxError, RuntimeError):
    """A results file that cannot be used as asked (exists, wrong kind, mismatching run)."""
