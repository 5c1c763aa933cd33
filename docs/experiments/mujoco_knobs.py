"""Which of MuJoCo's own settings decides whether an evolved gait falls there? (docs/results/closed-loop.md)

Each run's plain best is replayed in MuJoCo C as `cpgjax transfer` replays it (flat ground, its episode, once as
it is and 32 times with its genes jittered by sd 1e-3, the same jitter), with the exported model as it is and
with one of MuJoCo's settings changed at a time: the friction cone elliptic instead of pyramidal, `impratio` 10
(friction constraints 10x harder than the normal ones), 3 no-slip iterations (no creep of a sticking foot), a
1 ms step, RK4 or Euler instead of implicitfast, and the contacts' `solimp` harder (0.99 0.99 0.001).  Printed
per run and setting: falls of the 32 and the unjittered replay's speed (m/s).  Run:

    .venv/bin/python docs/experiments/mujoco_knobs.py RUN.h5 [RUN.h5 ...]
    .venv/bin/python docs/experiments/mujoco_knobs.py --convergence RUN.h5 [...]   # the step and integrator alone
    .venv/bin/python docs/experiments/mujoco_knobs.py --contact RUN.h5 [...]       # the ground's stiffness at 0.5 ms
    .venv/bin/python docs/experiments/mujoco_knobs.py --steps --terrain rough:0.02:0.1:1 RUN.h5 [...]
                                              # the step alone, 2 ms to 0.125 ms, on another terrain than the run's

``--terrain T`` replays on T (``--terrain`` syntax, the same field in both engines) instead of the run's terrain.
"""

import os
import sys

import numpy as np

import cpgjax  # noqa: F401  (first: the host devices)
from cpgjax.crosscheck.engines import mujoco_run
from cpgjax.crosscheck.mjcf import load
from cpgjax.crosscheck.transfer import _model, jittered, run_setting
from cpgjax.episode.policy import family_from_meta, from_genomes
from cpgjax.io.results import read_run

REPLAYS = 32


def settings(mujoco):
    def opt(**kw):
        def f(mj):
            for k, v in kw.items():
                setattr(mj.opt, k, v)
        return f

    def solimp(mj):
        mj.geom_solimp[:] = [0.99, 0.99, 0.001, 0.5, 2.0]

    integrator = mujoco.mjtIntegrator
    return {"as exported": None, "elliptic": opt(cone=mujoco.mjtCone.mjCONE_ELLIPTIC),
            "impratio10": opt(impratio=10.0), "noslip3": opt(noslip_iterations=3), "dt1ms": opt(timestep=0.001),
            "RK4": opt(integrator=integrator.mjINT_RK4), "Euler": opt(integrator=integrator.mjINT_EULER),
            "solimp.99": solimp}


def convergence(mujoco):
    """The step and the integrator alone: implicitfast (the export's) at 2, 1, 0.5 and 0.25 ms, RK4 at 2, 1, 0.5 ms."""
    def step(dt, integrator=None):
        def f(mj):
            mj.opt.timestep = dt
            if integrator is not None:
                mj.opt.integrator = integrator
        return f

    rk4 = mujoco.mjtIntegrator.mjINT_RK4
    return {"implicitfast 2 ms": None, "1 ms": step(1e-3), "0.5 ms": step(5e-4), "0.25 ms": step(2.5e-4),
            "RK4 2 ms": step(2e-3, rk4), "RK4 1 ms": step(1e-3, rk4), "RK4 0.5 ms": step(5e-4, rk4)}


def steps(mujoco):
    """The step alone (implicitfast, the export's integrator): 2, 1, 0.5, 0.25 and 0.125 ms."""
    def step(dt):
        def f(mj):
            mj.opt.timestep = dt
        return f

    return {"2 ms": None, "1 ms": step(1e-3), "0.5 ms": step(5e-4), "0.25 ms": step(2.5e-4),
            "0.125 ms": step(1.25e-4)}


def contact(mujoco):
    """The ground's stiffness and damping in MuJoCo at a fine step (0.5 ms): the export's `solref` (eq. 3.7's A and B
    per unit of the mass a resting foot carries), 4x stiffer and 2x more damped (the same damping ratio), a quarter
    as stiff and half as damped, and the export's with `solimp` 0.99 (the constraint's force closer to the
    reference)."""
    def at(k=1.0, b=1.0, imp=None):
        def f(mj):
            mj.opt.timestep = 5e-4
            mj.geom_solref[:, 0] *= k
            mj.geom_solref[:, 1] *= b
            if imp is not None:
                mj.geom_solimp[:] = [imp, imp, 0.001, 0.5, 2.0]
        return f

    return {"0.5 ms": at(), "A x4, B x2": at(4.0, 2.0), "A /4, B /2": at(0.25, 0.5), "solimp 0.99": at(imp=0.99)}


def main(paths: list[str]) -> None:
    import mujoco

    groups = {"--convergence": convergence, "--contact": contact, "--steps": steps}
    terrain = None
    if "--terrain" in paths:
        i = paths.index("--terrain")
        terrain = paths[i + 1]
        paths = paths[:i] + paths[i + 2:]
    S = groups.get(paths[0], settings)(mujoco)
    paths = [p for p in paths if p not in groups]
    print("| run | " + " | ".join(S) + " |")
    print("|---|" + "---:|" * len(S))
    for path in paths:
        run = read_run(path)
        _, _, _, genome = run.best()
        _, time, evolved_on = run_setting(run)
        model = _model(str(run.meta["model_text"]), str(run.meta.get("model_path", path)), terrain or evolved_on,
                       None, None, run.pipeline)
        C = from_genomes(family_from_meta(run.meta), model, jittered(genome, REPLAYS))   # cpgjax transfer's jitter
        cells = []
        for change in S.values():
            mj = load(model)
            if change is not None:
                change(mj)
            r, _, _ = mujoco_run(model, C, time=float(time or model.time_max), mj=mj)
            cells.append(f"{int(np.asarray(r['fallen'])[1:].sum())}, {float(np.asarray(r['speed'])[0]):.2f}")
        print(f"| {os.path.basename(path)} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
