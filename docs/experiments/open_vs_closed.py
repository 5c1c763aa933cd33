"""Open-loop against closed-loop controllers on the same budget (docs/results/closed-loop.md).

Each controller family is evolved with `make run`'s recipe (the trot as the start, exact joints, 4 episodes of
domain randomisation per controller, population 20, 15 generations, 5 s episodes, pocket 4, gamma 0.01) on the
seeds below, fixed before any was run; the closed loop adds the linear feedback policy reading tilt, foot
contact and a bias (`--controller pmtg:tilt+contact+bias`), with one step of latency and 2 % sensor noise.  Each
run's plain best is then replayed by `cpgjax transfer` (here and in MuJoCo C, once as it is and 32 times
jittered) on flat ground and on 1, 2 and 4 cm of roughness (the same field in both engines).  Every command is
a `cpgjax` command; a run or replay already on disk is kept (the script resumes).  Run:

    .venv/bin/python docs/experiments/open_vs_closed.py [--seeds 200-209] [--out runs/open-vs-closed] [--isa AVX2]

It writes OUT/FAMILY-sSEED.h5, OUT/FAMILY-sSEED-TERRAIN/transfer.json, OUT/times.json (wall and CPU seconds of
each evolution) and, with --table, the results page's table and figure from what is on disk.
"""

import argparse
import json
import os
import resource
import subprocess
import sys
import time

RECIPE = ["--start", "models/quadruped-trot.ctl", "--pipeline", "exact", "--evaluation", "robust",
          "--population", "20", "--generations", "15", "--time", "5", "--pocket", "4", "--gamma", "0.01",
          "--chunk", "5", "--quiet"]
FAMILIES = {
    "open": ["--perturb", "preset=domain"],
    "closed": ["--perturb", "preset=domain,latency=1,noise=0.02", "--controller", "pmtg:tilt+contact+bias"],
}
TERRAINS = ["flat", "rough:0.01", "rough:0.02", "rough:0.04"]
CPGJAX = os.path.join(os.path.dirname(sys.executable), "cpgjax")


def seeds(spec: str) -> list[int]:
    a, _, b = spec.partition("-")
    return list(range(int(a), int(b or a) + 1))


def run(cmd: list[str]) -> tuple[float, float]:
    """Run a cpgjax command; its wall and CPU seconds (children's)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([CPGJAX, *cmd], check=True, stdout=subprocess.DEVNULL)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.perf_counter() - t0, (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def evolve_and_replay(out: str, seed_list: list[int], terrains: list[str]) -> None:
    os.makedirs(out, exist_ok=True)
    times_path = os.path.join(out, "times.json")
    times = json.load(open(times_path)) if os.path.exists(times_path) else {}
    for seed in seed_list:
        for fam, extra in FAMILIES.items():
            h5 = os.path.join(out, f"{fam}-s{seed}.h5")
            if not os.path.exists(h5):
                tmp = h5 + ".part.h5"
                wall, cpu = run(["evolve", "models/quadruped.wl", *RECIPE, *extra, "--seed", str(seed),
                                 "--out", tmp, "--overwrite"])
                os.replace(tmp, h5)
                times[f"{fam}-s{seed}"] = {"wall": wall, "cpu": cpu}
                json.dump(times, open(times_path, "w"), indent=1)
            for terrain in terrains:
                d = os.path.join(out, f"{fam}-s{seed}-{terrain.replace(':', '')}")
                if not os.path.exists(os.path.join(d, "transfer.json")):
                    args = ["transfer", h5, "--out", d]       # under XLA_FLAGS as the evolution
                    if terrain != "flat":
                        args += ["--terrain", terrain]
                    run(args)
            print(f"{fam} s{seed} done", flush=True)


def collect(out: str) -> list[dict]:
    rows = []
    for name in sorted(os.listdir(out)):
        p = os.path.join(out, name, "transfer.json")
        if not os.path.exists(p):
            continue
        fam_seed, _, terrain = name.partition("-s")[2].partition("-")
        fam = name.split("-s")[0]
        r = json.load(open(p))["runs"][0]
        rows.append({"family": fam, "seed": int(fam_seed), "terrain": terrain or "flat", "r": r})
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="200-209")
    ap.add_argument("--out", default="runs/open-vs-closed")
    ap.add_argument("--terrains", default=",".join(TERRAINS))
    ap.add_argument("--isa", default=None, help="also set XLA_FLAGS=--xla_cpu_max_isa=ISA (another rounding)")
    ap.add_argument("--table", action="store_true", help="only tabulate and plot what is on disk")
    a = ap.parse_args()
    if a.isa:
        os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") + f" --xla_cpu_max_isa={a.isa}").strip()
    if not a.table:
        evolve_and_replay(a.out, seeds(a.seeds), a.terrains.split(","))


if __name__ == "__main__":
    main()
