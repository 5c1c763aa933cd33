"""The machine a run records: its CPU, vector ISA and the versions that decide a run's numbers bit for bit.

A run file stores :func:`versions` (its ``versions`` attribute) and the :func:`machine` that computed each range of
its generations (``machines``, read back by :func:`run_machines`); ``--resume`` compares the last of them with this
one (:func:`machine_differences`).  The file's layout: :mod:`cpgjax.io.results`; why: docs/reproducibility.md.
"""

from __future__ import annotations

import contextlib
import json
import os
import platform
import sys
from collections.abc import Mapping
from typing import Any

import h5py
import numpy as np

from cpgjax._xla import cpu_model, isa


def _version(dist: str) -> str:
    from importlib import metadata

    try:
        return metadata.version(dist)
    except metadata.PackageNotFoundError:
        return "none"


def versions() -> dict[str, str]:
    """Versions of the packages and the machine that make a run reproducible (docs/reproducibility.md)."""
    import jax
    import jaxlib

    import cpgjax

    try:
        device = str(jax.devices()[0].device_kind)
    except Exception:  # pragma: no cover - no backend
        device = "unknown"
    return {"python": sys.version.split()[0], "cpgjax": cpgjax.__version__, "jax": jax.__version__,
            "jaxlib": jaxlib.__version__, "mujoco": _version("mujoco"), "numpy": np.__version__,
            "h5py": h5py.__version__, "platform": platform.platform(), "device": device, "cpu": cpu_model(),
            "isa": isa(), "xla_flags": os.environ.get("XLA_FLAGS", "")}


# what decides a run's numbers bit for bit (besides its settings): the machine's CPU and vector ISA, and the
# versions of the code that compiles and runs the simulator (jax, jaxlib) and of cpgjax (and MuJoCo, for
# what is replayed in it)
MACHINE_KEYS = ("cpu", "isa", "cpgjax", "jax", "jaxlib", "mujoco")


def machine(v: Mapping[str, Any] | None = None) -> dict[str, str]:
    """The entries of :func:`versions` (default: this process's) that a run's numbers depend on."""
    v = versions() if v is None else v
    return {k: str(v[k]) for k in MACHINE_KEYS if k in v and v[k] not in (None, "")}


def describe_machine(m: Mapping[str, Any]) -> str:
    """``AMD EPYC (AVX512), cpgjax 0.1.0, jax 0.10.2, jaxlib 0.10.2, mujoco 3.3.7`` (what is known of it)."""
    cpu = m.get("cpu", "unknown CPU") + (f" ({m['isa']})" if m.get("isa") else "")
    return ", ".join([cpu] + [f"{k} {m[k]}" for k in ("cpgjax", "jax", "jaxlib", "mujoco") if m.get(k)])


def run_machines(attrs: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The machines that computed a run: ``[{"from_generation": 0, cpu, isa, ...}, ...]`` (files written before
    the ``machines`` attribute: the one of ``versions``, with what it recorded)."""
    with contextlib.suppress(ValueError, TypeError):
        if attrs.get("machines"):
            return list(json.loads(attrs["machines"]))
    try:
        v = json.loads(attrs.get("versions") or "{}")
    except ValueError:
        v = {}
    return [{"from_generation": 0, **machine(v)}]


def machine_differences(stored: Mapping[str, Any], here: Mapping[str, Any] | None = None) -> list[str]:
    """``["isa AVX512 -> SSE4_2", ...]``: what differs between a recorded machine and this one (keys the record
    lacks, as in files written before they were recorded, are not compared)."""
    here = machine() if here is None else here
    return [f"{k} {stored[k]} -> {here.get(k, 'unknown')}" for k in MACHINE_KEYS
            if stored.get(k) not in (None, "") and str(stored[k]) != str(here.get(k, ""))]
