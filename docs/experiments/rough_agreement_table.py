"""The summary table of docs/experiments/rough_agreement.sh: one row per pipeline and terrain, from the
``crosscheck.json`` that ``cpgjax crosscheck --out`` wrote.

    python docs/experiments/rough_agreement_table.py runs/rough-agreement
"""

from __future__ import annotations

import glob
import json
import os
import sys


def row(s: dict) -> str:
    lo, hi = s["ci_penalty_mujoco"]
    r = s["ratio_penalty_mujoco"]
    ratio = f"{r['median']:.2f} ({r['q1']:.2f}–{r['q3']:.2f}), {r['n']}" if r["n"] else "–"
    ceil = [f"{s[k]:.2f}" if k in s else "–" for k in ("rho_mujoco_half", "rho_penalty_half")]
    return (f"| {s['penalty_pipeline']} | {s['terrain']} | {s['rho_penalty_mujoco']:.2f} [{lo:.2f}, {hi:.2f}] | "
            f"{ceil[0]} | {ceil[1]} | {ratio} | {s['falls_penalty']} / {s['falls_mujoco']} of {s['n']} |")


def main(out: str) -> None:
    found = [json.load(open(p))["summary"] for p in glob.glob(os.path.join(out, "*", "crosscheck.json"))]

    def key(s):
        t = s["terrain"]
        level = 0.0 if t == "flat" else float(t.split(":")[1])
        return (s["penalty_pipeline"] != "springs", level, t)

    print("| pipeline | terrain | Spearman vs MuJoCo [95 %] | MuJoCo vs itself at 1 ms | ours vs itself at half "
          "the step | distance MuJoCo / ours: median (quartiles), controllers that walk in both | fell: ours / "
          "MuJoCo |")
    print("|---|---|---|---:|---:|---|---:|")
    for s in sorted(found, key=key):
        print(row(s))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "runs/rough-agreement")
