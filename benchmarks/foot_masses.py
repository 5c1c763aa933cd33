"""How heavy MuJoCo C's feet are to the ground while a gait walks: each foot sphere's effective vertical mass
``1 / (J_z M^-1 J_z^T)`` (:func:`cpgjax.crosscheck.impedance.vertical_masses`), sampled every 2 ms while it touches.

MuJoCo's contact stiffness is per unit mass; the export sets it for the mass a resting foot carries (``m_c``), so a
foot of effective mass ``m`` meets a ground ``m / m_c`` as stiff as eq. 3.7's (docs/crosscheck.md, *The ground's
units*).  Printed per foot: the 5th, 50th and 95th percentiles over its touching samples, and ``m_c``.

    .venv/bin/python benchmarks/foot_masses.py [--ctl models/quadruped-trot.ctl] [--terrain rough:0.02:0.1:1] \\
        [--time 4] [--mujoco-dt 0.00025]
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

MODEL = "models/quadruped.wl"
SAMPLE = 0.002      # s


def foot_masses(model, coeffs, *, time: float, timestep: float) -> dict[str, np.ndarray]:
    """{foot sphere's name: its effective vertical masses [kg] at the samples at which it touches}: the open-loop
    CPG ``coeffs`` [n_ctrl, 2K+1] walking ``time`` s in MuJoCo C at ``timestep`` (the export's contact law)."""
    from cpgjax.crosscheck.engines import controls, foot_geoms
    from cpgjax.crosscheck.impedance import from_rest, step, vertical_masses
    from cpgjax.crosscheck.mjcf import load

    mj = load(model, timestep=timestep)
    nstep = int(round(time / timestep))
    every = max(1, int(round(SAMPLE / timestep)))
    u = controls(model, np.asarray(coeffs)[None], nstep, timestep)[0]
    feet = np.nonzero(foot_geoms(model, mj) >= 0)[0]
    d = from_rest(model, mj, None, 0)
    out: dict[str, list] = {mj.geom(int(g)).name: [] for g in feet}
    for s in range(nstep):
        d.ctrl[:] = u[s]
        step(mj, d, None, 0)
        if (s + 1) % every:
            continue
        touching = set(d.contact.geom[: d.ncon].ravel().tolist())
        m = vertical_masses(mj, d, feet)
        for g, mg in zip(feet, m, strict=True):
            if int(g) in touching:
                out[mj.geom(int(g)).name].append(mg)
    return {k: np.asarray(v) for k, v in out.items()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--ctl", default="models/quadruped-trot.ctl", help="an open-loop CPG (default: the trot)")
    p.add_argument("--terrain", default="rough:0.02:0.1:1")
    p.add_argument("--time", type=float, default=4.0, help="seconds walked (default 4)")
    p.add_argument("--mujoco-dt", type=float, default=0.00025, help="MuJoCo C's step (default 0.00025)")
    a = p.parse_args(argv)
    from cpgjax.crosscheck.mjcf import contact_mass
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    model = load_model(MODEL, terrain=a.terrain, pipeline="exact")
    coeffs = read_ctl(a.ctl, n_dof=model.n_ctrl, harmonics=model.episode.harmonics).coeffs
    masses = foot_masses(model, coeffs, time=a.time, timestep=a.mujoco_dt)
    print(f"{a.ctl} on {a.terrain}, {a.time:g} s in MuJoCo C at {a.mujoco_dt * 1e3:g} ms; the export's m_c = "
          f"{contact_mass(model):.2f} kg")
    print("| foot | touching samples | effective vertical mass [kg], 5 / 50 / 95 % |")
    print("|---|---:|---|")
    for name, m in masses.items():
        pct = " / ".join(f"{x:.2f}" for x in np.percentile(m, [5, 50, 95])) if len(m) else "—"
        print(f"| {name} | {len(m)} | {pct} |")
    every = np.concatenate([m for m in masses.values() if len(m)])
    print(f"| all | {len(every)} | " + " / ".join(f"{x:.2f}" for x in np.percentile(every, [5, 50, 95])) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
