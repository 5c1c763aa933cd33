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


# The suite's tiny GA runs of the quadruped, made once per test process and shared by every file that needs a run
# file (transfer, validation, replay, render, the pipeline records): one compiled GA program per evaluation, where
# each file made its own runs with settings of its own before.  Settings: 0.3 s episodes, 6 robots, 2 generations,
# a pocket of 2, seed 3; the robust run as the recommended recipe evaluates (README): a fall scales the score, the
# foot's bristle up to 10^3 stiffer, 2 replicas.
TINY_GA = ["--time", "0.3", "--population", "6", "--generations", "2", "--pocket", "2", "--seed", "3", "--quiet"]
TINY_TIME = 0.3
TINY_ROBUST = ["--evaluation", "robust", "--perturb", "replicas=2,fall_survival=on,bristle=3"]


# The suite's tiny sweep of the analytic problem: 2 gammas x 2 pocket sizes x cross-over off/on x 2 seeds, random
# search, amc and CMA-ES, one compiled program shared by experiments/test_sweep.py and analysis/test_report.py (the
# drivers are the same for every problem; the quadruped's own sweep is in the slow tests).
TINY_SWEEP = ["sweep", "analytic:sphere:10", "--gamma", "0,1", "--pocket", "0,2", "--crossover", "off,on",
              "--population", "6", "--seeds", "2", "--baselines", "random,amc3,cmaes", "--quiet"]


class TinyRuns:
    """``runs["thesis"]``, ``runs["robust"]``: paths of run files made on first use (read them, or copy them to
    change them: other tests read the same files)."""

    def __init__(self, folder):
        self.folder = folder
        self._made: dict[str, str] = {}

    def __getitem__(self, kind: str) -> str:
        if kind not in self._made:
            from cpgjax import cli

            out = str(self.folder / f"{kind}.h5")
            extra = {"thesis": [], "robust": TINY_ROBUST}[kind]
            assert cli.main(["evolve", "models/quadruped.wl", *TINY_GA, *extra, "--out", out]) == 0
            self._made[kind] = out
        return self._made[kind]


def one_line_error(err: str, command: str, expect=(), absent=()) -> None:
    """``err`` (a command's stderr) is one line, ``cpgjax COMMAND: error: ...``, with each of ``expect`` in it and
    none of ``absent``: the project's rule for bad input."""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    assert lines[0].startswith(f"cpgjax {command}: error: "), err
    for text in expect:
        assert text in lines[0], err
    for text in absent:
        assert text not in lines[0], err
