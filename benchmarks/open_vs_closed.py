"""Open-loop against closed-loop controllers on the same budget (docs/results/closed-loop.md).

Each controller family is evolved with `make run`'s recipe (the trot as the start, exact joints, 4 episodes of
domain randomisation per controller, population 20, 15 generations, 5 s episodes, pocket 4, gamma 0.01) on the
seeds below, fixed before any was run; the closed loop adds the linear feedback policy reading tilt, foot
contact and a bias (`--controller pmtg:tilt+contact+bias`), with one step of latency and 2 % sensor noise.  Each
run's plain best is then replayed by `cpgjax transfer` (here and in MuJoCo C, once as it is and 32 times
jittered) on flat ground and on 1, 2 and 4 cm of roughness (the same field in both engines).  Every command is
a `cpgjax` command; a run or replay already on disk is kept (the script resumes).  Run:

    .venv/bin/python benchmarks/open_vs_closed.py [--seeds 200-209] [--out runs/open-vs-closed] [--isa AVX2]

It writes OUT/FAMILY-sSEED.h5, OUT/FAMILY-sSEED-TERRAIN/transfer.json, OUT/times.json (wall and CPU seconds of
each evolution) and, with --table, the results page's table and figure from what is on disk.
"""

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time

RECIPE = ["--start", "models/quadruped-trot.ctl", "--pipeline", "exact", "--evaluation", "robust",
          "--population", "20", "--generations", "15", "--time", "5", "--pocket", "4", "--gamma", "0.01",
          "--chunk", "5", "--quiet"]
FAMILIES = {
    "open": ["--perturb", "preset=domain"],
    "closed": ["--perturb", "preset=domain,latency=1,noise=0.02", "--controller", "pmtg:tilt+contact+bias"],
    # the open loop with twice the evaluation budget: 8 episodes per controller, or 30 generations
    "open8ep": ["--perturb", "preset=domain,replicas=8"],
    "open30gen": ["--perturb", "preset=domain", "--generations", "30"],
    # the open loop evolved under ten times the gene jitter (sd 0.01 rad), alone and with 8 episodes
    "openj10": ["--perturb", "preset=domain,jitter=0.01"],
    "openj10x8": ["--perturb", "preset=domain,jitter=0.01,replicas=8"],
    # the closed loop with a mirror-symmetric genome (the right legs evolved, the left derived)
    "closedmirror": ["--perturb", "preset=domain,latency=1,noise=0.02",
                     "--controller", "pmtg:tilt+contact+bias:mirror"],
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


def evolve_and_replay(out: str, seed_list: list[int], terrains: list[str], families: list[str]) -> None:
    """Every family's run on every seed and its replays on every terrain, each a ``cpgjax`` command (:func:`run`);
    what is on disk is kept."""
    os.makedirs(out, exist_ok=True)
    times_path = os.path.join(out, "times.json")
    times = json.load(open(times_path)) if os.path.exists(times_path) else {}
    for seed in seed_list:
        for fam in families:
            extra = FAMILIES[fam]
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


def _cm(terrain: str) -> float:
    return 0.0 if terrain == "flat" else float(terrain.removeprefix("rough")) * 100


def table(out: str) -> str:
    """The results page's tables (every seed, then per family and terrain) from what is on disk."""
    from cpgjax.crosscheck.transfer import failures, verdict

    rows = collect(out)
    times = json.load(open(os.path.join(out, "times.json")))
    fams = [f for f in FAMILIES if any(r["family"] == f for r in rows)]
    terrains = sorted({r["terrain"] for r in rows}, key=_cm)

    def fails(r):
        x = r["r"]
        return failures(x["ours"]["fitness"], x["ours"]["speed"], x["ours"]["fallen"], x["mujoco"]["fitness"],
                        x["mujoco_jit"]["falls"])

    lines = ["Every seed on flat ground (the run's plain best, its 5 s episode; speed here / in MuJoCo C, m/s; "
             "falls of 32 jittered replays here / in MuJoCo C):", "",
             "| seed | " + " | ".join(f"{f}: speed here / MuJoCo, falls, carries over" for f in fams) + " |",
             "|---:|" + "---|" * len(fams)]
    for seed in sorted({r["seed"] for r in rows}):
        cells = []
        for f in fams:
            m = [r for r in rows if r["family"] == f and r["seed"] == seed and r["terrain"] == "flat"]
            if not m:
                cells.append("")
                continue
            x = m[0]["r"]
            fell = lambda d: " (fell)" if d["fallen"] else ""  # noqa: E731
            cells.append(f"{x['ours']['speed']:.3f}{fell(x['ours'])} / {x['mujoco']['speed']:.3f}{fell(x['mujoco'])}, "
                         f"{x['ours_jit']['falls']} / {x['mujoco_jit']['falls']}, {verdict(fails(m[0]))}")
        lines.append(f"| {seed} | " + " | ".join(cells) + " |")
    lines += ["", "Per family and ground (medians over the seeds; a run stays up when its replay as it is does not "
              "fall and at most 2 of its 32 jittered replays do; carries over: the rule of `cpgjax transfer` on "
              "that ground):", "",
              "| controller | ground | runs | speed here (median) | speed MuJoCo C (median) | stays up here | "
              "stays up in MuJoCo C | carries over |", "|---|---|---:|---:|---:|---:|---:|---:|"]
    for f in fams:
        for t in terrains:
            m = [r for r in rows if r["family"] == f and r["terrain"] == t]
            n = len(m)
            med = {k: float(statistics.median(r["r"][k]["speed"] for r in m)) for k in ("ours", "mujoco")}
            up = {k: sum(not r["r"][k]["fallen"] and r["r"][k + "_jit"]["falls"] <= 2 for r in m)
                  for k in ("ours", "mujoco")}
            carried = sum(not fails(r) for r in m)
            ground = "flat" if t == "flat" else f"rough {_cm(t):g} cm"
            lines.append(f"| {f} | {ground} | {n} | {med['ours']:.3f} | {med['mujoco']:.3f} | {up['ours']} "
                         f"| {up['mujoco']} | {carried} of {n} |")
    cost = []
    for f in fams:
        t = [v for k, v in times.items() if k.startswith(f + "-")]
        wall, cpu = [v["wall"] for v in t], [v["cpu"] for v in t]
        cost.append(f"{f}-loop {statistics.median(wall):.0f} s wall ({min(wall):.0f}-{max(wall):.0f}), "
                    f"{statistics.median(cpu):.0f} s CPU")
    lines += ["", "One evolution, compile included (median and range over the seeds; the persistent compilation "
              "cache warm after each family's first run): " + "; ".join(cost) + "."]
    return "\n".join(lines)


def plot(out: str, path: str) -> None:
    """Speed against roughness, per controller family and engine: each seed a thin line, the median a thick one."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = collect(out)
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    colors = {"open": "tab:blue", "closed": "tab:red", "open8ep": "tab:green", "open30gen": "tab:purple",
              "openj10": "tab:orange", "openj10x8": "tab:brown", "closedmirror": "tab:pink"}
    for f in FAMILIES:
        for engine, style in (("ours", "-"), ("mujoco", "--")):
            by_seed: dict = {}
            for r in rows:
                if r["family"] == f:
                    d = r["r"][engine]
                    by_seed.setdefault(r["seed"], {})[_cm(r["terrain"])] = (d["speed"], d["fallen"])
            if not by_seed:
                continue
            xs = sorted({x for d in by_seed.values() for x in d})
            for d in by_seed.values():
                ax.plot(xs, [d.get(x, (float("nan"), False))[0] for x in xs], style, color=colors[f], lw=0.5,
                        alpha=0.35)
                fell = [x for x in xs if x in d and d[x][1]]
                ax.plot(fell, [d[x][0] for x in fell], "x", color=colors[f], ms=5, alpha=0.8)
            med = [statistics.median(d[x][0] for d in by_seed.values() if x in d) for x in xs]
            ax.plot(xs, med, style, color=colors[f], lw=2.2, marker="o",
                    label=f"{f}-loop, {'here' if engine == 'ours' else 'MuJoCo C'} (median)")
    ax.axhline(0.42, color="0.4", lw=0.8, ls=":")
    ax.text(0.05, 0.425, "the thesis's 0.42 m/s", fontsize=8, color="0.3", va="bottom")
    ax.set_xlabel("roughness of the ground [cm]")
    ax.set_ylabel("speed of the run's best, as it is [m/s]")
    ax.set_title("open- vs closed-loop, same budget; thin: each seed, x: it fell")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="200-209")
    ap.add_argument("--out", default="runs/open-vs-closed")
    ap.add_argument("--terrains", default=",".join(TERRAINS))
    ap.add_argument("--families", default="open,closed", help=f"comma-separated, of {', '.join(FAMILIES)}")
    ap.add_argument("--isa", default=None, help="also set XLA_FLAGS=--xla_cpu_max_isa=ISA (another rounding)")
    ap.add_argument("--table", action="store_true", help="only tabulate (and plot) what is on disk")
    ap.add_argument("--figure", default=None, help="also draw speed against roughness into this file")
    a = ap.parse_args(argv)
    unknown = sorted(set(a.families.split(",")) - set(FAMILIES))
    if unknown:
        ap.error(f"--families: unknown {', '.join(unknown)} (of {', '.join(FAMILIES)})")
    if a.isa:
        os.environ["XLA_FLAGS"] = (os.environ.get("XLA_FLAGS", "") + f" --xla_cpu_max_isa={a.isa}").strip()
    if not a.table:
        evolve_and_replay(a.out, seeds(a.seeds), a.terrains.split(","), a.families.split(","))
    print(table(a.out))
    if a.figure:
        plot(a.out, a.figure)
        print(f"wrote {a.figure}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
