"""Why MuJoCo and our simulator parted on rough ground, and what the export does about it (docs/crosscheck.md).

The hand-written trot for 10 s in MuJoCo C on flat ground and on 0.5, 2 and 4 cm of roughness, under four
exports of the same model: the foot spheres' radius, whether the robot starts on the field or in it (its `.wl`
pose stands on z = 0, so on a rough field its feet start up to RANGE inside it), and the heightfield's grid
(ours, or sampled 4x finer from our bilinear surface).  Per case: the distance walked, the share of the feet's
contacts whose normal points more than 45 degrees from vertical (a sphere pushed sideways by a heightfield
prism's wall), the feet's penetration (median and 99th percentile) and the share of touching feet with more
than one contact (one per prism they touch).  Our simulator's distances are printed beside them.

    python docs/experiments/rough_contacts.py          # about 2 min on 2 cores
"""

from __future__ import annotations

import numpy as np


def main() -> None:
    import mujoco

    from cpgjax.crosscheck.engines import controls, metrics_from_qpos
    from cpgjax.crosscheck.mjcf import initial_qpos, to_mjcf
    from cpgjax.episode.batch import simulate
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    T = 10.0
    trot = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs
    variants = [("2 mm spheres, started in the field, its grid", 0.002, False, 1),
                ("2 mm spheres, started on the field, its grid", 0.002, True, 1),
                ("1 cm spheres, started on the field, its grid", 0.01, True, 1),
                ("1 cm spheres, started on the field, 4x grid (the export)", 0.01, True, None)]
    print("| terrain | export | MuJoCo distance [m] | contacts > 45 deg from vertical | penetration median / 99 % "
          "[mm] | feet with > 1 contact | ours: springs / exact [m] |")
    print("|---|---|---:|---:|---:|---:|---|")
    for spec in ("flat", "rough:0.005", "rough:0.02", "rough:0.04"):
        ours = []
        for pipe in ("springs", "exact"):
            ours.append(float(simulate(load_model("models/quadruped.wl", terrain=spec, pipeline=pipe), trot,
                                       time=T)["distance"]))
        for label, radius, lifted, sub in variants:
            model = load_model("models/quadruped.wl", terrain=spec)
            if not lifted:       # the .wl pose on the field's terrain: built on flat ground, the field put under it
                model = load_model("models/quadruped.wl").replace(terrain=model.terrain)
            mj = mujoco.MjModel.from_xml_string(to_mjcf(model, contact_radius=radius, hfield_sub=sub))
            d = mujoco.MjData(mj)
            d.qpos[:] = initial_qpos(model, mj)
            mujoco.mj_forward(mj, d)
            u = controls(model, trot[None], int(round(T / mj.opt.timestep)), mj.opt.timestep)[0]
            qpos, nz, depth, multi = [d.qpos.copy()], [], [], []
            for uk in u:
                d.ctrl[:] = uk
                mujoco.mj_step(mj, d)
                qpos.append(d.qpos.copy())
                per = {}
                for j in range(d.ncon):
                    c = d.contact[j]
                    nz.append(abs(c.frame[2]))
                    depth.append(-c.dist)
                    per[c.geom2] = per.get(c.geom2, 0) + 1
                multi += [n > 1 for n in per.values()]
            dist = metrics_from_qpos(model, mj, np.array(qpos)[None], mj.opt.timestep)["distance"][0]
            nz, depth = np.array(nz), np.array(depth) * 1e3
            print(f"| {spec} | {label} | {dist:+.3f} | {np.mean(nz < np.cos(np.pi / 4)):.1%} | "
                  f"{np.median(depth):.2f} / {np.quantile(depth, 0.99):.2f} | {np.mean(multi):.1%} | "
                  f"{ours[0]:+.3f} / {ours[1]:+.3f} |", flush=True)


if __name__ == "__main__":
    main()
