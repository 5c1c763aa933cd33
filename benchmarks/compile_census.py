"""Where the test suite's time goes: every XLA compile of a pytest run, timed (docs/architecture.md, Tests).

A pytest plugin: each compile JAX asks XLA for is logged, through JAX's event listeners (`jax.monitoring`), with
its program's name, wall and CPU seconds, whether the persistent compilation cache answered it, the cache's key
of the program (a hash of the program and its compile options: the same key, the same program; "-" when the cache
is off) and the test that asked; then this file, run as a script, sums the logs up: how much of the suite's CPU
is compiling, in how many programs, whether any program was compiled twice, and the heaviest ones.  Run:

    COMPILE_CENSUS=runs/compile-census PYTHONPATH=benchmarks .venv/bin/python -m pytest -p compile_census \\
        -q -n 2 --dist loadfile --no-loadscope-reorder -m "not slow"
    .venv/bin/python benchmarks/compile_census.py runs/compile-census

(One TSV per test process in the folder; subprocesses the tests start are not counted.)  The key is read from
the line JAX logs at each lookup of its persistent cache (its debug logging of compiles, which the options
``jax_log_compiles`` and ``jax_explain_cache_misses`` raise to warnings), on the logger named
``jax._src.compiler``: a logger's name, nothing imported from JAX's internals.
"""

from __future__ import annotations

import argparse
import collections
import glob
import logging
import os
import sys
import threading
import time

COMPILE = "/jax/core/compile/backend_compile_duration"     # JAX's event around each compile: started, then done
HIT = "/jax/compilation_cache/cache_hits"                  # the persistent cache answered
CACHE_LOGGER = "jax._src.compiler"                          # logs "... cache hit/MISS for NAME with key KEY"


class _Keys(logging.Handler):
    """Takes the program's key from JAX's persistent-cache lines; passes on what the logger's parent would show."""

    def __init__(self, census: Census, parent: logging.Logger):
        super().__init__(logging.DEBUG)
        self.census, self.parent = census, parent

    def emit(self, record: logging.LogRecord) -> None:
        text = str(record.msg)
        if ("cache hit for" in text or "CACHE MISS for" in text) and len(record.args or ()) == 2:
            self.census.key(str(record.args[0]), str(record.args[1]))
        if record.levelno >= self.parent.getEffectiveLevel():
            self.parent.handle(record)


class Census:
    """Writes one tab-separated line per XLA compile of this process to ``path`` (appended) until :meth:`close`:
    name, wall s, CPU s, 1 if the persistent cache answered, the program's key, the test."""

    def __init__(self, path: str):
        from jax import monitoring

        self.out = open(path, "a")
        self.now = threading.local()
        self.logger = logging.getLogger(CACHE_LOGGER)
        self.saved = self.logger.level, self.logger.propagate
        self.handler = _Keys(self, self.logger.parent or logging.getLogger())
        self.logger.addHandler(self.handler)
        self.logger.setLevel(logging.DEBUG)
        self.logger.propagate = False          # the handler passes on what would have been shown
        monitoring.register_scalar_listener(self.started)
        monitoring.register_event_listener(self.event)
        monitoring.register_event_duration_secs_listener(self.done)

    def _current(self) -> dict | None:
        return getattr(self.now, "compile", None)

    def started(self, event: str, value, **kw) -> None:
        if event == COMPILE:
            self.now.compile = {"cpu": time.process_time(), "hit": False, "key": "-", "name": kw.get("fun_name", "?")}

    def event(self, event: str, **kw) -> None:
        if event == HIT and self._current() is not None:
            self._current()["hit"] = True

    def key(self, name: str, key: str) -> None:
        if self._current() is not None:
            self._current().update(name=name, key=key.rsplit("-", 1)[-1][:16])

    def done(self, event: str, duration: float, **kw) -> None:
        c = self._current()
        if event != COMPILE or c is None:
            return
        self.now.compile = None
        test = os.environ.get("PYTEST_CURRENT_TEST", "?").rsplit(" (", 1)[0]
        self.out.write(f"{c['name']}\t{duration:.3f}\t{time.process_time() - c['cpu']:.3f}\t"
                       f"{int(c['hit'])}\t{c['key']}\t{test}\n")
        self.out.flush()

    def close(self) -> None:
        from jax import monitoring

        monitoring.unregister_scalar_listener(self.started)
        monitoring.unregister_event_listener(self.event)
        monitoring.unregister_event_duration_listener(self.done)
        self.logger.removeHandler(self.handler)
        self.logger.setLevel(self.saved[0])        # (setLevel, not the attribute: it clears logging's level cache)
        self.logger.propagate = self.saved[1]
        self.out.close()


def pytest_configure(config):
    folder = os.environ.get("COMPILE_CENSUS", "runs/compile-census")
    os.makedirs(folder, exist_ok=True)
    census = Census(os.path.join(folder, f"{os.environ.get('PYTEST_XDIST_WORKER', 'main')}-{os.getpid()}.tsv"))
    config.add_cleanup(census.close)


def summary(folder: str, top: int = 25) -> str:
    """The census of the TSV files in ``folder``: compiles, programs of 0.5 s CPU or more, repeats, the heaviest."""
    rows = []
    for path in glob.glob(os.path.join(folder, "*.tsv")):
        for line in open(path):
            name, wall, cpu, hit, key, test = line.rstrip("\n").split("\t")
            rows.append((name, float(wall), float(cpu), hit == "1", key, test))
    misses = [r for r in rows if not r[3]]
    big = [r for r in misses if r[2] >= 0.5]
    count = collections.Counter(r[4] for r in misses if r[4] != "-")
    twice = {k for k, n in count.items() if n > 1}
    big_twice = [r for r in big if r[4] in twice]
    unkeyed = sum(r[4] == "-" for r in misses)
    lines = [f"{len(rows)} compiles, {sum(r[2] for r in rows):.0f} s CPU; {len(rows) - len(misses)} read from the "
             f"persistent cache ({sum(r[2] for r in rows if r[3]):.1f} s)",
             f"{len(big)} programs of 0.5 s CPU or more: {sum(r[2] for r in big):.0f} s; "
             f"{len(misses) - len(big)} smaller (op by op and the like): "
             f"{sum(r[2] for r in misses if r[2] < 0.5):.0f} s",
             f"programs XLA compiled more than once (in one process or in several): {len(twice)}, of them of 0.5 s "
             f"or more: {len({r[4] for r in big_twice})} ({sum(r[2] for r in big_twice):.1f} s in all their compiles)"
             + (f"; {unkeyed} compiles without a key (the persistent cache off), not counted" if unkeyed else ""),
             "", "heaviest (CPU s, program, test):"]
    lines += [f"{r[2]:6.2f}  {r[0]:<24} {r[5]}" for r in sorted(big, key=lambda r: -r[2])[:top]]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="The census of a pytest run's compiles, from the plugin's TSV files "
                                             "(this file's docstring has the two commands).")
    ap.add_argument("folder", nargs="?", default="runs/compile-census", help="default runs/compile-census")
    ap.add_argument("--top", type=int, default=25, help="the heaviest programs listed (default 25)")
    a = ap.parse_args(argv)
    if not glob.glob(os.path.join(a.folder, "*.tsv")):
        ap.error(f"{a.folder}: no .tsv file of the plugin here")
    print(summary(a.folder, a.top))
    return 0


if __name__ == "__main__":
    sys.exit(main())
