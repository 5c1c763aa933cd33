"""XLA settings that must be in place before JAX is imported (one small, named place).

Why: on CPU, XLA runs one program mostly on one core; the fastest way we measured to
use every core for a batch of independent robots is one *host device* per core and
the batch split across them (`cpgjax.episode.batch`).  That needs
``--xla_force_host_platform_device_count`` set before ``import jax``.  This module is
imported first by ``cpgjax/__init__.py``; if JAX was already imported (e.g. by a
notebook), the flag cannot take effect and cpgjax falls back to the devices it has.
Set ``CPGJAX_DEVICES=1`` to opt out, or to a number to choose the device count.
`cpgjax bench` reports robot-steps per second for 1 device and for all of them.

Second, ``--xla_cpu_experimental_ynn_fusion_type=`` (empty: no YNNPACK fusions).  Why: from 96 robots
per device, this jaxlib's XLA hands the simulator's ``reduce_sum`` reductions to the YNNPACK library,
which sums in another order, so a robot's score depended on the size of the batch it was in (by 7e-3 to
1e-2 in fitness from batch 88 on one device and 176 on two; below that the programs are the same).  A
sweep's results must equal the same run made alone (docs/sweeps.md), and a replay must score what the GA
recorded.  Without these fusions every batch size gives the same numbers and small batches are unchanged
bit for bit (``tests/episode/test_rollout.py``); measured beside it, batch 512 was not slower (3.1 s
against 4.6 s for 512 robot-seconds on 2 cores).  The flag is specific to the pinned jaxlib (0.10.x).
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
    if "xla_cpu_experimental_ynn_fusion_type" not in flags:
        flags += " --xla_cpu_experimental_ynn_fusion_type="
    os.environ["XLA_FLAGS"] = flags.strip()
