"""A setting of MuJoCo's side held for the length of a ``with`` block (the ground's form, the contact law, the
friction cone, the contact stiffness): commands that run MuJoCo take it without threading it through."""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Iterator
from typing import TypeVar

T = TypeVar("T")


@contextlib.contextmanager
def scoped(var: contextvars.ContextVar[T], value: T | None) -> Iterator[None]:
    """Within this block ``var`` holds ``value`` (None: unchanged); checked by the caller before."""
    if value is None:
        yield
        return
    token = var.set(value)
    try:
        yield
    finally:
        var.reset(token)
