"""Helpers for the tests of run files (evolve, sweep)."""

from __future__ import annotations

import numpy as np


def same_rows(a, b, n=None):
    """Two read-back runs (:class:`cpgjax.io.results.Run`) hold bit for bit the same first ``n`` rows."""
    n = n if n is not None else max(a.completed, b.completed)
    assert a.completed >= n and b.completed >= n
    for name in ("genomes", "fitness", "diverged", "n_diverged", "mutation_rate"):
        np.testing.assert_array_equal(getattr(a, name)[:n], getattr(b, name)[:n], err_msg=name)
    for group in ("metrics", "state"):
        ga_, gb = getattr(a, group), getattr(b, group)
        assert set(ga_) == set(gb)
        for k in ga_:
            np.testing.assert_array_equal(ga_[k][:n], gb[k][:n], err_msg=f"{group}/{k}")


def other_machine() -> dict[str, str]:
    """A machine that differs from this one in every field a run records (CPU, vector ISA, every version),
    whatever this host is: a faked machine built from the real one, never a named CPU that some host has."""
    from cpgjax.io.results import ISAS, machine

    here = machine()
    other = {k: f"{v}+other" for k, v in here.items()}
    other["cpu"] = f"Other CPU (not {here.get('cpu', 'this one')})"
    other["isa"] = next(i for i in ISAS if i != here.get("isa"))
    return other
