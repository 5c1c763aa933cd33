"""The kernels one exact-joint step launches: counted in XLA's compiled program, not timed.

    CPGJAX_DEVICES=1 python docs/experiments/step_kernels.py [MODEL.wl] [BATCH]

Compiles a `jax.lax.scan` of 10 steps of BATCH robots (default the quadruped, 16: the GA's robots per
device) and counts the operations of the loop's body that XLA's CPU runtime runs one by one (fusions,
copies, loops, conditionals, ...; not the tuples, parameters and bitcasts, which cost nothing), with
those of a conditional's taken branch (`keep`'s first form: a ``cond`` that always took its second branch)
and of a zero-trip loop's condition (`keep`'s form now).  A loop that does work (the contact solve's, run once
or, when some vertex is to be released, twice: `sim/exact/contact.py: _release`) is counted apart: its body's
kernels run once per pass.  At 16 robots a step's time is about this count times 100 ns
(docs/results/performance.md, "The exact pipeline").
"""

import collections
import re
import sys

import jax
import jax.numpy as jnp

from cpgjax.io.wl import load_model
from cpgjax.sim import initial_state, step

FREE = {"parameter", "get-tuple-element", "tuple", "constant", "bitcast"}


def computations(text):
    comps, cur = {}, None
    for line in text.splitlines():
        m = re.match(r"^(ENTRY )?%([\w.\-]+) .*\{$", line)
        if m:
            cur = m.group(2)
            comps[cur] = []
        elif line.startswith("}"):
            cur = None
        elif cur and " = " in line:
            comps[cur].append(line)
    return comps


def opcode(line):
    rhs = re.sub(r"/\*[^*]*\*/", "", line.split(" = ", 1)[1])
    m = re.match(r"(\([^=]*?\)|\S+) ([a-z][\w\-]*)\(", rhs)
    return m.group(2) if m else "?"


WORK = 20   # a loop whose body launches more kernels than this does work (`keep`'s bodies: one fusion)
LOOPS = []  # the bodies of such loops, counted apart


def count(comps, name):
    c = collections.Counter()
    for line in comps[name]:
        op = opcode(line)
        if op in FREE:
            continue
        c[op] += 1
        if op == "conditional":
            c.update(count(comps, re.search(r"branch_computations=\{([^}]*)\}", line).group(1).split(", ")[-1][1:]))
        if op == "while":
            c.update(count(comps, re.search(r"condition=%([\w.\-]+)", line).group(1)))
            inner = count(comps, re.search(r"body=%([\w.\-]+)", line).group(1))
            if sum(inner.values()) > WORK:
                LOOPS.append(inner)
    return c


if __name__ == "__main__":
    wl = sys.argv[1] if len(sys.argv) > 1 else "models/quadruped.wl"
    batch = int(sys.argv[2]) if len(sys.argv) > 2 else 16
    model = load_model(wl, pipeline="exact")
    s = initial_state(model, batch)
    tgt = jnp.zeros((model.n_ctrl, batch), jnp.float32)
    run = jax.jit(lambda s, c: jax.lax.scan(lambda s, _: (step(model, s, c), None), s, None, length=10)[0])
    comps = computations(run.lower(s, (tgt, tgt)).compile().as_text())
    body = max((c for c in comps if "region_0" in c), key=lambda c: len(comps[c]))   # the scan's body
    c = count(comps, body)
    what = ", ".join(f"{k} {v}" for k, v in c.most_common())
    print(f"{wl}, {batch} robots: {sum(c.values())} kernels per step ({what})")
    for inner in LOOPS:
        what = ", ".join(f"{k} {v}" for k, v in inner.most_common())
        print(f"  and a loop doing work, {sum(inner.values())} kernels per pass ({what})")
