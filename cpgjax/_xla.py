"""XLA settings that must be in place before JAX is imported (one small, named place).

Why: on CPU, XLA runs one program mostly on one core; the fastest way we measured to
use every core for a batch of independent robots is one *host device* per core and
the batch split across them (`cpgjax.episode.batch`).  That needs
``--xla_force_host_platform_device_count`` set before ``import jax``.  This module is
imported first by ``cpgjax/__init__.py``; if JAX was already imported (e.g. by a
notebook), the flag cannot take effect and cpgjax falls back to the devices it has.
Set ``CPGJAX_DEVICES=1`` to opt out, or to a number to choose the device count.
`cpgjax bench` reports robot-steps per second for 1 device and for all of them.
"""

from __future__ import annotations

import os
import sys


def configure() -> None:
    if "jax" in sys.modules:
        return
    n = os.environ.get("CPGJAX_DEVICES")
    count = int(n) if n else (os.cpu_count() or 1)
    flags = os.environ.get("XLA_FLAGS", "")
    if "xla_force_host_platform_device_count" not in flags and count > 1:
        flags += f" --xla_force_host_platform_device_count={count}"
    os.environ["XLA_FLAGS"] = flags.strip()
