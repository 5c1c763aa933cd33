"""Where a program's compile goes: XLA's kernels of the episode program, by kind and by the source line they come
from (docs/results/performance-exact.md, *Compile*).

The program is `cpgjax bench`'s (one episode of ``--batch`` robots, its ahead-of-time ``lower().compile()``), compiled
twice with JAX's persistent cache off: once timed alone, once with XLA's dump switched on through JAX's public
``compiler_options`` (``xla_dump_to``), from which every kernel's LLVM IR after optimisation is read.  XLA's CPU
back end turns each fused loop of the optimised program into one such kernel; most of a long compile is LLVM
optimising and emitting them, so each kernel's IR size is this report's measure of its share (a proxy: LLVM's time
per kernel is not logged).  A kernel's kind is read off the name XLA gives a fusion (the operations it fuses:
``bitcast_concatenate_fusion.5``), its source line from the fusion's own metadata (the innermost frame JAX
recorded: the line of ``cpgjax`` that made the fusion's root operation).

    .venv/bin/python benchmarks/compile_anatomy.py [MODEL.wl] [--pipeline exact] \\
        [--batch 20] [--time 1] [--top 12] [--keep DIR]
"""

from __future__ import annotations

import argparse
import collections
import glob
import os
import re
import sys
import tempfile
import time

KINDS = ("concatenate", "reduce", "gather", "scatter", "dynamic-update-slice", "dynamic-slice", "dot", "sort")
KERNEL = re.compile(r"\.(?P<name>[^.]+(?:\.\d+)?)_kernel_module\.ir-with-opt\.ll$")
SECTIONS = ("FileNames", "FunctionNames", "FileLocations", "StackFrames")


def kind(kernel: str) -> str:
    """The kernel's kind by the operations its fusion's name lists (``add_concatenate_fusion.2``: concatenate)."""
    ops = kernel.split(".")[0].replace("dynamic_update_slice", "dynamic-update-slice")
    ops = ops.replace("dynamic_slice", "dynamic-slice").split("_")
    return next((k for k in KINDS if k in ops), "elementwise")


def _frames(hlo: str) -> tuple[dict, dict, dict, dict]:
    """The stack-frame tables XLA prints before the program: file names, function names, locations, frames."""
    tables: dict[str, dict] = {s: {} for s in SECTIONS}
    section = None
    for line in hlo.splitlines():
        s = line.strip()
        if s in SECTIONS:
            section = s
            continue
        if s.startswith(("%", "ENTRY")):
            if section == "StackFrames":
                break
            continue
        m = re.match(r"(\d+) (.*)", s)
        if m and section:
            i, rest = int(m.group(1)), m.group(2)
            tables[section][i] = (rest.strip('"') if section in ("FileNames", "FunctionNames")
                                  else dict(re.findall(r"(\w+)=(\w+)", rest)))
    return tables["FileNames"], tables["FunctionNames"], tables["FileLocations"], tables["StackFrames"]


def sources(hlo: str, root: str = "") -> dict[str, str]:
    """{fusion's name: "file:line function"} for every fusion of the optimised program ``hlo`` (its innermost
    recorded frame; paths relative to ``root``)."""
    files, funcs, locs, frames = _frames(hlo)
    out = {}
    for m in re.finditer(r"^\s*(?:ROOT )?%(\S+) = .*? fusion\(.*?stack_frame_id=(\d+)", hlo, re.MULTILINE):
        fr = frames.get(int(m.group(2)))
        loc = locs.get(int(fr["file_location_id"])) if fr else None
        if not loc:
            continue
        path = files.get(int(loc["file_name_id"]), "?")
        path = os.path.relpath(path, root) if root and os.path.isabs(path) else path
        out[m.group(1)] = f"{path}:{loc.get('line', '?')} {funcs.get(int(loc.get('function_name_id', 0)), '')}"
    return out


def anatomy(lowered, dump_dir: str, root: str = "") -> dict:
    """Compile ``lowered`` (a ``jax.jit(...).lower(...)``) once timed and once dumped into ``dump_dir``; return the
    compile's seconds and its kernels: ``[(name, kind, IR bytes, source)]``, the largest first."""
    import jax

    # JAX's persistent cache keys a program without its dump options: the first compile is not written to it, so
    # that the second one compiles (and dumps) too
    keep = jax.config.jax_persistent_cache_min_compile_time_secs
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1e9)
    try:
        t0 = time.perf_counter()
        lowered.compile()
        seconds = time.perf_counter() - t0
        lowered.compile(compiler_options={"xla_dump_to": dump_dir, "xla_dump_hlo_as_text": True})
    finally:
        jax.config.update("jax_persistent_cache_min_compile_time_secs", keep)
    after = sorted(glob.glob(os.path.join(dump_dir, "*.cpu_after_optimizations.txt")), key=os.path.getmtime)
    if not after:
        raise RuntimeError(f"XLA compiled nothing into {dump_dir}: the program came from JAX's persistent "
                           "compilation cache (run with CPGJAX_COMPILE_CACHE=0)")
    prefix = after[-1][:-len("cpu_after_optimizations.txt")]
    src = sources(open(after[-1]).read(), root)
    kernels = []
    for path in glob.glob(prefix + "*_kernel_module.ir-with-opt.ll"):
        name = KERNEL.search(path).group("name")
        kernels.append((name, kind(name), os.path.getsize(path), src.get(name, "?")))
    kernels.sort(key=lambda k: -k[2])
    return {"compile_s": seconds, "kernels": kernels}


def table(result: dict, top: int = 12) -> list[str]:
    """The report's lines: totals, the kinds, the source lines and the ``top`` heaviest kernels (Markdown tables)."""
    ks = result["kernels"]
    total = sum(k[2] for k in ks) or 1
    lines = [f"compile: {result['compile_s']:.2f} s; {len(ks)} kernels, {total / 1e6:.2f} MB of optimised LLVM IR", ""]

    def group(col, title):
        by = collections.defaultdict(lambda: [0, 0])
        for k in ks:
            by[k[col]][0] += 1
            by[k[col]][1] += k[2]
        rows = sorted(by.items(), key=lambda kv: -kv[1][1])
        out = [f"| {title} | kernels | IR [MB] | share |", "|---|---:|---:|---:|"]
        return out + [f"| {key} | {n} | {b / 1e6:.2f} | {100 * b / total:.0f} % |" for key, (n, b) in rows[:top]] + [""]

    lines += group(1, "kind") + group(3, "source line")
    lines += ["| kernel | kind | IR [MB] | source line |", "|---|---|---:|---|"]
    lines += [f"| {n} | {kd} | {b / 1e6:.2f} | {s} |" for n, kd, b, s in ks[:top]]
    return lines


def episode_program(model_path: str, pipeline: str | None, batch: int, time_s: float):
    """`cpgjax bench`'s program (:func:`cpgjax.experiments.bench.episode_program`) for the model file, lowered."""
    from cpgjax.experiments.bench import episode_program as bench_program
    from cpgjax.io.wl import load_model

    f, coeffs = bench_program(load_model(model_path, pipeline=pipeline), batch, time_s)
    return f.lower(coeffs)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="compile_anatomy.py", description=__doc__.split("\n\n")[0])
    p.add_argument("model", nargs="?", default="models/quadruped.wl", metavar="MODEL.wl")
    p.add_argument("--pipeline", choices=("springs", "exact"), default=None,
                   help="the physics pipeline (default: the model file's)")
    p.add_argument("--batch", type=int, default=20, help="robots in the episode (default 20)")
    p.add_argument("--time", type=float, default=1.0, help="simulated seconds (data, not compiled in; default 1)")
    p.add_argument("--top", type=int, default=12, help="rows of each table (default 12)")
    p.add_argument("--keep", metavar="DIR", help="dump into DIR and keep it (default: a folder removed at the end)")
    a = p.parse_args(argv)
    if a.batch < 1 or a.top < 1 or a.time <= 0:
        p.error("--batch and --top must be at least 1, --time above 0")
    if not os.path.isfile(a.model):
        p.error(f"{a.model}: no such model file")
    os.environ["CPGJAX_COMPILE_CACHE"] = "0"            # a cold compile, and one that XLA dumps
    os.environ.pop("JAX_COMPILATION_CACHE_DIR", None)
    import cpgjax  # noqa: F401  (its XLA settings before JAX)

    lowered = episode_program(a.model, a.pipeline, a.batch, a.time)
    with tempfile.TemporaryDirectory() as tmp:
        result = anatomy(lowered, a.keep or tmp, root=os.getcwd())
    lines = table(result, a.top)
    print(f"{a.model}, pipeline {a.pipeline or 'of the file'}, {a.batch} robots: {lines[0]}")
    print("\n".join(lines[1:]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
