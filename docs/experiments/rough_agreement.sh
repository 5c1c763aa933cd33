#!/bin/sh
# The engines' agreement on rough ground, measured as on flat ground (docs/results/engine-agreement.md):
# the default cross-check set (8 random controllers, 16 perturbed trots, seed 0) on flat ground and on
# 1, 2, 3 and 4 cm of roughness, three fields each (seeds 0, 1, 2, fixed before any was run), on both
# physics pipelines; each command's table in OUT/PIPELINE-TERRAIN/crosscheck.md and .json, then the summary
# table (docs/experiments/rough_agreement_table.py).  About 1 min per command on 2 cores.
#
#   sh docs/experiments/rough_agreement.sh [OUT]        # default runs/rough-agreement
set -e
OUT=${1:-runs/rough-agreement}
CPGJAX=${CPGJAX:-.venv/bin/cpgjax}
for P in springs exact; do
    [ -f "$OUT/$P-flat/crosscheck.json" ] || \
        $CPGJAX crosscheck models/quadruped.wl --no-mjx --random 8 --perturbed 16 --pipeline $P --out "$OUT/$P-flat"
    for R in 0.01 0.02 0.03 0.04; do
        for F in 0 1 2; do
            T=rough:$R:0.1:$F
            [ -f "$OUT/$P-$T/crosscheck.json" ] || \
                $CPGJAX crosscheck models/quadruped.wl --no-mjx --random 8 --perturbed 16 --pipeline $P \
                    --terrain $T --out "$OUT/$P-$T"
        done
    done
done
.venv/bin/python docs/experiments/rough_agreement_table.py "$OUT"
