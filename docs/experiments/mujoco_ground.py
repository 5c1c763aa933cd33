"""How deep MuJoCo's exported ground lets a resting robot sink, against eq. 3.7, and what a ground that rests as eq. 3.7
does to carry-over (docs/results/engine-agreement.md, "MuJoCo's ground at rest").

The export gives MuJoCo ``solref = -A/m_c -B/m_c`` (`crosscheck.mjcf.contact_solref`), eq. 3.7's stiffness and
damping per unit of the mass a resting contact carries.  At rest MuJoCo's soft constraint holds a contact where its
reference acceleration equals the regularisation times the force, ``k imp r = R f`` with ``R = (1 - imp) / imp x
diagApprox`` (MuJoCo's constant estimate of the contact's inverse mass, from the bodies' ``invweight0``), so the
depth depends on the body the contact is on, not only on ``k``.  Printed first: the quadruped holding its mean pose
for 3 s (MuJoCo at 2 and 0.5 ms) and a 13.8 kg box resting on four corners, per foot or corner the force, depth and
force per depth, beside eq. 3.7's ``f / A``.

Then, with run files: each run's plain best replayed as ``cpgjax transfer`` replays it (flat ground, once as it is
and 32 times jittered) with MuJoCo's ground as exported and with a ground that rests as eq. 3.7 (every ``solref``
scaled by ``--scale``, 4 by default, and the contacts' ``solimp`` width 0.1 mm instead of 1 mm, so that the
impedance is constant at the resting depth), each at MuJoCo's 2 and 0.5 ms step; printed: each run's verdict and
the counts.

    .venv/bin/python docs/experiments/mujoco_ground.py                       # the resting depths, seconds
    .venv/bin/python docs/experiments/mujoco_ground.py runs/carry/*.h5 runs/carry-fresh/*.h5   # about 6 min
"""

from __future__ import annotations

import argparse
import os
import sys

import numpy as np

import cpgjax  # noqa: F401  (first: the host devices)
import cpgjax.crosscheck.transfer as transfer
from cpgjax.crosscheck import mjcf

WIDTH = 1e-4        # m: the contacts' solimp width of the ground that rests as eq. 3.7


def rest(model, mj, ctrl, seconds: float = 3.0):
    """(force [n], depth [n]) of each contact vertex after ``seconds`` in MuJoCo C holding ``ctrl`` (or nothing)."""
    import mujoco

    d = mujoco.MjData(mj)
    d.qpos[:] = mjcf.initial_qpos(model, mj)
    mujoco.mj_forward(mj, d)
    for _ in range(int(round(seconds / mj.opt.timestep))):
        if ctrl is not None:
            d.ctrl[:] = ctrl
        mujoco.mj_step(mj, d)
    f, depth, f6 = np.zeros(len(model.ct_pt)), np.zeros(len(model.ct_pt)), np.zeros(6)
    for i in range(d.ncon):
        con = d.contact[i]
        g = con.geom2 if mj.geom(con.geom2).name != "ground" else con.geom1
        k = int(mj.geom(g).name.rsplit("_c", 1)[1])
        mujoco.mj_contactForce(mj, d, i, f6)
        f[k] += f6[0]
        depth[k] = max(depth[k], -con.dist)
    return f, depth


def resting_depths(scale: float) -> None:
    sys.path.insert(0, "tests")
    from simcases import box

    from cpgjax.crosscheck.engines import controls
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    quad = load_model("models/quadruped.wl", pipeline="exact")
    c = np.asarray(read_ctl("models/quadruped-trot.ctl", n_dof=quad.n_ctrl, harmonics=quad.harmonics).coeffs).copy()
    c[:, 1:] = 0.0                                               # the trot's mean pose, held
    hold = controls(quad, c[None], 1, 0.002)[0, 0]
    print("| body | MuJoCo | ground | force per foot or corner [N] | depth [mm] | eq. 3.7's depth f / A [mm] | "
          "force / depth [N/m] (A = 1e5) |")
    print("|---|---|---|---|---|---|---|")
    cases = [("quadruped, mean pose", quad, hold, dt) for dt in (2e-3, 5e-4)]
    cases.append(("box 13.8 kg", box(z=0.05, mass=13.8), None, 2e-3))
    for name, m, ctrl, dt in cases:
        for label, s, w in (("as exported", 1.0, None), (f"solref x{scale:g}, width {WIDTH * 1e3:g} mm", scale, WIDTH)):
            mj = grounded(mjcf.load(m, timestep=dt), s, w)
            f, d = rest(m, mj, ctrl)
            on = d > 0
            if not on.any():
                print(f"| {name} | {dt * 1e3:g} ms | {label} | no contact after 3 s (it bounces) | | | |")
                continue
            fmt = lambda x, k=1, on=on: ", ".join(f"{v * k:.3g}" for v in x[on])  # noqa: E731
            print(f"| {name} | {dt * 1e3:g} ms | {label} | {fmt(f)} | {fmt(d, 1e3)} | {fmt(f / m.ground_A, 1e3)} | "
                  f"{fmt(f / np.where(on, d, 1.0))} |")


def grounded(mj, scale: float, width: float | None):
    """The exported MjModel with every geom's solref scaled and, with ``width``, the solimp width set."""
    mj.geom_solref[:] *= scale
    if width is not None:
        mj.geom_solimp[:, 2] = width
    return mj


def carry_over(paths: list[str], scale: float) -> None:
    load = transfer.load
    settings = [("as exported, 2 ms", 1.0, None, None), ("as exported, 0.5 ms", 1.0, None, 5e-4),
                ("rests as eq. 3.7, 2 ms", scale, WIDTH, None), ("rests as eq. 3.7, 0.5 ms", scale, WIDTH, 5e-4)]
    verdicts = {}
    try:
        for label, s, w, dt in settings:
            transfer.load = lambda model, s=s, w=w, **kw: grounded(load(model, **kw), s, w)
            rs = transfer.replay_runs(paths, mujoco_dt=dt)
            verdicts[label] = {os.path.basename(r.run): r for r in rs}
            print(f"{label}: {sum(r.carries_over for r in rs)} of {len(rs)} carry over", flush=True)
    finally:
        transfer.load = load
    names = list(next(iter(verdicts.values())))
    print("\n| run | " + " | ".join(verdicts) + " |")
    print("|---|" + "---|" * len(verdicts))
    for n in names:
        cells = [f"{'yes' if v[n].carries_over else 'no'} ({v[n].mujoco_jit['falls']})" for v in verdicts.values()]
        print(f"| {n} | " + " | ".join(cells) + " |")
    vs = list(verdicts.values())
    print(f"\ncarry over under all four: {sum(all(v[n].carries_over for v in vs) for n in names)} of {len(names)}; "
          "verdicts changed by the ground: "
          f"{sum(vs[0][n].carries_over != vs[2][n].carries_over for n in names)} at 2 ms, "
          f"{sum(vs[1][n].carries_over != vs[3][n].carries_over for n in names)} at 0.5 ms; by the step: "
          f"{sum(vs[0][n].carries_over != vs[1][n].carries_over for n in names)} as exported")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="*", help="run files whose plain bests are judged under each ground")
    ap.add_argument("--scale", type=float, default=4.0, help="solref scale of the ground that rests as eq. 3.7")
    a = ap.parse_args()
    resting_depths(a.scale)
    if a.runs:
        print()
        carry_over(a.runs, a.scale)


if __name__ == "__main__":
    main()
