"""Output paths: checked before any work (a command never computes for minutes and then fails to write)."""

from __future__ import annotations

import os


def first_existing(path: str) -> str:
    """The nearest of ``path`` and its parents (as written) that exists (``.`` for a relative path's root)."""
    p = path or "."
    while not os.path.lexists(p):
        parent = os.path.dirname(p)
        if not parent or parent == p:
            return parent or "."
        p = parent
    return p
