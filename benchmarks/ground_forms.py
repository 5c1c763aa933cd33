"""Does MuJoCo's verdict depend on the ground's form?  (docs/crosscheck.md, *The ground's form in MuJoCo*.)

Replays controllers in MuJoCo C on rough fields exported as each form (``hfield``, ``mesh``, ``boxes``:
``cpgjax.crosscheck.ground``) at each MuJoCo step, and prints per case the distance walked, whether the body fell,
and how deep the foot spheres went into the ground: the sphere's lowest point below our surface under its centre
(the exported surface is the same in every form, within 0.5 mm), sampled every 2 ms, its 99th percentile and
maximum over the feet and the episode, and the share of the feet's contacts pushing more than 45 degrees
from vertical.

    python benchmarks/ground_forms.py                    # the docs' table: about 10 min on 2 cores
    python benchmarks/ground_forms.py --time 0.2 --seeds 1 --dts 0.002 --forms hfield mesh   # a smoke run
"""

from __future__ import annotations

import argparse
import sys
import time as _time

import numpy as np

CTLS = (("trot (exact)", "models/quadruped-trot.ctl", "exact"), ("robust", "models/quadruped-robust.ctl", None))


def foot_contacts(model, mj, qpos: np.ndarray, every: int):
    """(depth [samples, feet], tilted): how far each foot sphere's lowest point lies below MuJoCo's surface under its
    centre [m], and the share of the feet's contacts whose normal points more than 45 degrees from vertical (a sphere
    pushed sideways: by a heightfield prism's wall, or a piece's side), every ``every``-th state of ``qpos``.  The
    export lowers our surface h by the radius r, so the depth is h - r - (z - r) = h - z, z the sphere's centre."""
    import mujoco

    from cpgjax.crosscheck.engines import foot_geoms

    foot = foot_geoms(model, mj) >= 0
    gids = np.nonzero(foot)[0]
    d = mujoco.MjData(mj)
    pos, nz = [], []
    for q in qpos[::every]:
        d.qpos[:] = q
        mujoco.mj_kinematics(mj, d)
        mujoco.mj_collision(mj, d)
        pos.append(d.geom_xpos[gids].copy())
        c = d.contact[: d.ncon]
        on_foot = foot[c.geom1] | foot[c.geom2]
        nz.extend(np.abs(c.frame[on_foot, 2]).tolist())
    p = np.asarray(pos)                                            # [S, feet, 3]
    tilted = float(np.mean(np.asarray(nz) < np.cos(np.pi / 4))) if nz else 0.0
    return model.terrain.height_np(p[..., 0], p[..., 1]) - p[..., 2], tilted


def run(fields, dts, forms, time: float, out=sys.stdout) -> list[dict]:
    from cpgjax.crosscheck.engines import mujoco_run
    from cpgjax.crosscheck.mjcf import load
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    rows = []
    print("| controller | field | MuJoCo step [ms] | form | distance [m] | fell | feet below surface 99 % / max "
          "[mm] | contacts > 45 deg from vertical | wall [s] |", file=out)
    print("|---|---|---:|---|---:|---|---:|---:|---:|", file=out)
    for label, ctl, pipeline in CTLS:
        for spec in fields:
            model = load_model("models/quadruped.wl", terrain=spec, pipeline=pipeline)
            coeffs = read_ctl(ctl, n_dof=model.n_ctrl, harmonics=model.episode.harmonics).coeffs[None]
            for dt in dts:
                for form in forms:
                    t0 = _time.perf_counter()
                    mj = load(model, timestep=dt, ground=form)
                    met, qpos, _ = mujoco_run(model, coeffs, time=time, mj=mj, timestep=dt)
                    depth, tilted = foot_contacts(model, mj, qpos[0], max(1, int(round(0.002 / dt))))
                    row = {"controller": label, "field": spec, "dt": dt, "form": form,
                           "distance": float(met["distance"][0]), "fell": bool(met["fallen"][0]),
                           "depth99": float(np.percentile(depth, 99)), "depth_max": float(depth.max()),
                           "tilted": tilted,
                           "wall": _time.perf_counter() - t0}
                    rows.append(row)
                    print(f"| {label} | {spec} | {dt * 1e3:g} | {form} | {row['distance']:.3f} | "
                          f"{'fell' if row['fell'] else 'no'} | {row['depth99'] * 1e3:.1f} / "
                          f"{row['depth_max'] * 1e3:.1f} | {100 * tilted:.1f} % | {row['wall']:.0f} |", file=out,
                          flush=True)
    return rows


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3, 4], help="rough:0.02:0.1:SEED (default 1 2 3 4)")
    p.add_argument("--dts", type=float, nargs="+", default=[0.00025, 0.002], help="MuJoCo steps [s]")
    p.add_argument("--forms", nargs="+", default=["hfield", "mesh", "boxes"], help="the ground's forms")
    p.add_argument("--time", type=float, default=10.0, help="episode [s] (default 10)")
    a = p.parse_args(argv)
    from cpgjax.crosscheck.ground import check_form

    try:
        for f in a.forms:
            check_form(f)
        if min(a.seeds) < 0 or a.time <= 0 or min(a.dts) <= 0:
            raise ValueError("--time and --dts must be positive, --seeds non-negative")
    except ValueError as e:
        print(f"ground_forms.py: {e}", file=sys.stderr)
        return 2
    run([f"rough:0.02:0.1:{s}" for s in a.seeds], a.dts, a.forms, a.time)
    return 0


if __name__ == "__main__":
    sys.exit(main())
