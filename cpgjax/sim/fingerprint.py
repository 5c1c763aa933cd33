"""A structural fingerprint of a frozen model: what its compiled programs are cached by.

The programs close over a :class:`~cpgjax.sim.model.Model`'s arrays as constants, so two models with the same
arrays, settings and description compile to the same program: the model hashes and compares by this
fingerprint (``Model.__hash__``, ``__eq__``), and a cache keyed by the model serves every model of that
structure (one loaded twice from a file, or rebuilt by ``replace`` with the same values), not only the same object.
"""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np


def _feed(h, x) -> None:
    if x is None or isinstance(x, (bool, int, float, complex, str, bytes)):
        h.update(f"{type(x).__name__}:{x!r};".encode())
    elif hasattr(x, "__array__") and hasattr(x, "dtype"):      # numpy and JAX arrays, numpy scalars
        a = np.ascontiguousarray(np.asarray(x))
        h.update(f"array:{a.dtype.str}:{a.shape};".encode())
        h.update(a.tobytes() if a.dtype != object else repr(a.tolist()).encode())
    elif dataclasses.is_dataclass(x) and not isinstance(x, type):
        h.update(f"{type(x).__qualname__}(".encode())
        for f in dataclasses.fields(x):
            h.update(f"{f.name}=".encode())
            _feed(h, getattr(x, f.name))
        h.update(b")")
    elif isinstance(x, (tuple, list, frozenset, set)):
        h.update(f"{type(x).__name__}[".encode())
        for v in (sorted(x, key=repr) if isinstance(x, (set, frozenset)) else x):
            _feed(h, v)
        h.update(b"]")
    elif isinstance(x, dict):
        h.update(b"dict{")
        for k in sorted(x, key=repr):
            _feed(h, k)
            _feed(h, x[k])
        h.update(b"}")
    else:
        h.update(f"{type(x).__qualname__}:{x!r};".encode())


def fingerprint(x) -> str:
    """The SHA-256 of every field of ``x``, recursively (arrays by dtype, shape and bytes)."""
    h = hashlib.sha256()
    _feed(h, x)
    return h.hexdigest()
