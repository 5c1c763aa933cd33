"""Which XLA options make the episode programs compile faster, and do they keep the bits (docs/results/performance.md).

For each option (none first), in a fresh process with the compilation cache off: the compile of the quadruped's
episode program (`episode.batch.evaluate`, 32 robots, 0.5 s) on the springs and on the exact pipeline, CPU
seconds, and a hash of every result of the episode (a different hash: the option changes the numbers, so every
figure measured without it would move).  Run:

    .venv/bin/python docs/experiments/compile_flags.py
"""

import os
import subprocess
import sys

OPTIONS = [
    "",
    "--xla_llvm_disable_expensive_passes=true",
    "--xla_backend_optimization_level=1",
    "--xla_backend_optimization_level=0",
    "--xla_backend_extra_options=xla_cpu_disable_slp_vectorizer=true",
    "--xla_backend_extra_options=xla_cpu_disable_tiled_emitter=true",
    "--xla_backend_extra_options=xla_cpu_optimize_for_size=true",
    "--xla_backend_extra_options=xla_cpu_use_multi_output_fusion=false",
    "--xla_backend_extra_options=xla_cpu_flatten_after_fusion=true",
]

ONE = """
import hashlib, time
from functools import partial
import jax, numpy as np
import cpgjax
from cpgjax.episode.batch import evaluate
from cpgjax.io.wl import load_model
out = []
for pipe in ("springs", "exact"):
    m = load_model("models/quadruped.wl", pipeline=pipe)
    C = np.random.default_rng(0).uniform(-0.5, 0.5, (32, 8, 5)).astype(np.float32)
    t = time.process_time()
    f = jax.jit(partial(evaluate, m, time=0.5)).lower(C).compile()
    ct = time.process_time() - t
    r = jax.tree.map(np.asarray, f(C))
    h = hashlib.sha1(b"".join(r[k].tobytes() for k in sorted(r))).hexdigest()[:10]
    out.append(f"{ct:5.2f} s {h}")
print(" | ".join(out))
"""


def main() -> None:
    print("| option | springs: compile, results' hash | exact: compile, results' hash |")
    print("|---|---|---|")
    for opt in OPTIONS:
        env = {**os.environ, "XLA_FLAGS": opt, "CPGJAX_COMPILE_CACHE": "0"}
        r = subprocess.run([sys.executable, "-c", ONE], env=env, capture_output=True, text=True, check=True)
        print(f"| {opt or '(none)'} | {r.stdout.strip().splitlines()[-1]} |")


if __name__ == "__main__":
    main()
