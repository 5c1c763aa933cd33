"""The exact pipeline's compile options (`cpgjax._xla.PROGRAM_OPTIONS`) against none and against others, side by side
in one process: the episode program's speed, its compile and its results' bits.

    CPGJAX_COMPILE_CACHE=0 python docs/experiments/program_options.py [PIPELINE] [BATCH] [SECONDS] [OPTIONS ...]

BATCH random controllers (default 20) of the quadruped on PIPELINE (exact, the default, or springs), one
`episode.batch.evaluate` of SECONDS (default 2) compiled ahead of time once per option set (its compile printed),
then the best of 3 calls timed (wall); a hash of every output: equal hashes, equal bits.  The option sets, in this
order: cpgjax's own for the pipeline ("program options", where it has some), none ("no options"), then each OPTIONS
argument, a JSON object of LLVM or XLA backend options that replaces cpgjax's for that program, e.g.
'{"-unroll-full-max-count": "4"}'.
"""

import hashlib
import json
import sys
import time
from functools import partial

# isort: off
import cpgjax  # noqa: F401  (cpgjax first: it sets the host devices before jax is imported)
# isort: on
import jax
import numpy as np

from cpgjax import _xla
from cpgjax.episode.batch import evaluate
from cpgjax.experiments.bench import _controllers
from cpgjax.io.wl import load_model


def measure(model, c, T):
    t0 = time.perf_counter()
    f = jax.jit(partial(evaluate, model, time=T)).lower(c).compile()
    compile_s = time.perf_counter() - t0
    out = jax.block_until_ready(f(c))
    best = np.inf
    for _ in range(3):
        t0 = time.perf_counter()
        jax.block_until_ready(f(c))
        best = min(best, time.perf_counter() - t0)
    h = hashlib.sha1(b"".join(np.asarray(x).tobytes() for x in jax.tree.leaves(out))).hexdigest()[:10]
    return compile_s, len(c) * T / best, h


if __name__ == "__main__":
    args = sys.argv[1:]
    pipeline = args.pop(0) if args and args[0] in ("exact", "springs") else "exact"
    batch = int(args.pop(0)) if args else 20
    T = float(args.pop(0)) if args else 2.0
    model = load_model("models/quadruped.wl", pipeline=pipeline)
    c = np.asarray(_controllers(model, batch), np.float32)
    own = dict(_xla.PROGRAM_OPTIONS.get(pipeline, {}))
    sets = ([("program options", own)] if own else []) + [("no options", None)] + [(a, json.loads(a)) for a in args]
    print(f"{pipeline} pipeline, {batch} robots, {T:g} s episodes, {len(jax.devices())} host devices; "
          f"program options: {own or 'none'}")
    for name, opts in sets:
        _xla.program_options_on = opts is not None
        _xla.PROGRAM_OPTIONS[pipeline] = opts or own
        compile_s, rate, h = measure(model, c, T)
        print(f"{name}: compile {compile_s:.2f} s, {rate:,.0f} robot-s per s, results {h}", flush=True)
