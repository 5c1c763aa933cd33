"""A smoke run of ``benchmarks/foot_masses.py`` (docs/crosscheck.md, *The ground's units*): the trot for 0.3 s in
MuJoCo C at 1 ms, its touching feet's effective vertical masses and the table."""

from __future__ import annotations

import numpy as np
from benchcases import load_benchmark


def test_the_feet_touching_have_masses_and_the_table_names_each(capsys):
    bench = load_benchmark("foot_masses")
    assert bench.main(["--time", "0.3", "--mujoco-dt", "0.001", "--terrain", "flat"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].endswith("the export's m_c = 3.45 kg") and out[1].startswith("| foot | touching samples |")
    rows = [r for r in out[3:] if r.startswith("| LegL")]
    assert len(rows) == 4 and out[-1].startswith("| all | ")
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    m = load_model("models/quadruped.wl")
    masses = bench.foot_masses(m, read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs, time=0.3,
                               timestep=0.001)
    every = np.concatenate(list(masses.values()))
    assert len(every) > 100 and np.all(np.isfinite(every)) and np.all(every > 0.05) and np.all(every < 14.0)
