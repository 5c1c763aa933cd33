"""Where the test suite's time goes: every XLA compile of a pytest run, timed (docs/architecture.md, Tests).

A pytest plugin: each compile JAX asks XLA for (`jax._src.compiler.compile_or_get_cached`) is logged with its
program's name, wall and CPU seconds, whether the persistent cache answered it, a hash of the program and the
test that asked; then this file, run as a script, sums the logs up: how much of the suite's CPU is compiling,
in how many programs, whether any program was compiled twice, and the heaviest ones.  Run:

    COMPILE_CENSUS=runs/compile-census PYTHONPATH=docs/experiments .venv/bin/python -m pytest -p compile_census \\
        -q -n 2 --dist loadfile --no-loadscope-reorder -m "not slow"
    .venv/bin/python docs/experiments/compile_census.py runs/compile-census

(One TSV per test process in the folder; subprocesses the tests start are not counted.  Timing a compile from
outside adds a hash of its program text, a few ms each.)
"""

import collections
import glob
import hashlib
import os
import sys
import time


def pytest_configure(config):
    from jax._src import compiler, monitoring

    folder = os.environ.get("COMPILE_CENSUS", "runs/compile-census")
    os.makedirs(folder, exist_ok=True)
    out = open(os.path.join(folder, f"{os.environ.get('PYTEST_XDIST_WORKER', 'main')}-{os.getpid()}.tsv"), "a")
    hits = [0]

    def on_event(event, **kw):
        if event == "/jax/compilation_cache/cache_hits":
            hits[0] += 1

    monitoring.register_event_listener(on_event)
    original = compiler.compile_or_get_cached

    def timed(backend, computation, *args, **kw):
        from jax._src.lib.mlir import ir

        name = ir.StringAttr(computation.operation.attributes["sym_name"]).value
        digest = hashlib.sha1(computation.operation.get_asm(enable_debug_info=False).encode()).hexdigest()[:12]
        h0, t0, c0 = hits[0], time.monotonic(), time.process_time()
        result = original(backend, computation, *args, **kw)
        test = os.environ.get("PYTEST_CURRENT_TEST", "?").rsplit(" (", 1)[0]
        out.write(f"{name}\t{time.monotonic() - t0:.3f}\t{time.process_time() - c0:.3f}\t{int(hits[0] > h0)}\t"
                  f"{digest}\t{test}\n")
        out.flush()
        return result

    compiler.compile_or_get_cached = timed


def summary(folder: str, top: int = 25) -> str:
    rows = []
    for path in glob.glob(os.path.join(folder, "*.tsv")):
        for line in open(path):
            name, wall, cpu, hit, digest, test = line.rstrip("\n").split("\t")
            rows.append((name, float(wall), float(cpu), hit == "1", digest, test))
    misses = [r for r in rows if not r[3]]
    big = [r for r in misses if r[2] >= 0.5]
    count = collections.Counter(r[4] for r in misses)
    twice = {d for d, n in count.items() if n > 1}
    big_twice = [r for r in big if r[4] in twice]
    lines = [f"{len(rows)} compiles, {sum(r[2] for r in rows):.0f} s CPU; {len(rows) - len(misses)} read from the "
             f"persistent cache ({sum(r[2] for r in rows if r[3]):.1f} s)",
             f"{len(big)} programs of 0.5 s CPU or more: {sum(r[2] for r in big):.0f} s; "
             f"{len(misses) - len(big)} smaller (op by op and the like): "
             f"{sum(r[2] for r in misses if r[2] < 0.5):.0f} s",
             f"programs XLA compiled more than once (in one process or in several): {len(twice)}, of them of 0.5 s "
             f"or more: {len({r[4] for r in big_twice})} ({sum(r[2] for r in big_twice):.1f} s in all their compiles)",
             "", "heaviest (CPU s, program, test):"]
    lines += [f"{r[2]:6.2f}  {r[0]:<24} {r[5]}" for r in sorted(big, key=lambda r: -r[2])[:top]]
    return "\n".join(lines)


if __name__ == "__main__":
    print(summary(sys.argv[1] if len(sys.argv) > 1 else "runs/compile-census"))
