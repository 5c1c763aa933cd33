"""Spearman between the "penalty fitness" columns of two `cpgjax crosscheck --out DIR` tables.

    python docs/experiments/spearman_tables.py DIR_A/crosscheck.md DIR_B/crosscheck.md

For the same controllers (the same `--random/--perturbed/--controllers/--seed`) run on two pipelines or
settings of our simulator, e.g. exact joints against the springs pipeline with stiff springs
(docs/results/exact-joints.md, note 3): one line, the rank correlation and its 95 % bootstrap interval over the
controllers (`crosscheck/engines.py: spearman_interval`).  The tables print 4 decimals, so near-equal scores
tie (ranked by their mean rank).
"""

import sys

import numpy as np

from cpgjax.crosscheck.engines import spearman, spearman_interval


def penalty_fitness(path):
    rows = {}
    for line in open(path):
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or not cells[2].lstrip("+-").replace(".", "").isdigit():
            continue
        rows[cells[0]] = float(cells[2])
    return rows


if __name__ == "__main__":
    a, b = penalty_fitness(sys.argv[1]), penalty_fitness(sys.argv[2])
    keys = [k for k in a if k in b]
    if len(keys) != len(a) or len(keys) != len(b):
        sys.exit(f"the tables name different controllers ({len(a)}, {len(b)}, {len(keys)} in common)")
    x, y = np.array([a[k] for k in keys]), np.array([b[k] for k in keys])
    lo, hi = spearman_interval(x, y)
    print(f"{len(keys)} controllers: Spearman {spearman(x, y):.2f} [{lo:.2f}, {hi:.2f}]")
