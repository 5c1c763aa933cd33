#!/bin/bash
# Exact joints as the limit of stiff springs (docs/results/exact-joints.md, "Exact joints as the limit of stiff springs").
#
#   bash docs/experiments/stiff_limit.sh EXACT_RUNS OUT
#
# EXACT_RUNS: a folder with the robust runs whose bests make the walking set (runs/exact2/robust: the sweep of
# docs/results/transfer.md, "On exact joints"); OUT: where the tables go.  The same 96 controllers (the 8 best of
# each robust run and 16 perturbed trots; then the random set, seed 0) on exact joints at 2 ms and on the springs
# pipeline with pivot springs of stiffness alpha (damping beta ~ sqrt(alpha)), each at a step small enough for it,
# then Spearman between the "penalty fitness" columns (spearman_tables.py).  About 25 min on 2 cores.
set -eu
E=$1; O=$2; mkdir -p "$O"
C="cpgjax"; P="python $(dirname "$0")/spearman_tables.py"
W="--controllers $(ls "$E"/*/s*.h5 | tr '\n' ' ') --random 0 --perturbed 16"
R="--random 32 --perturbed 64 --seed 0"
# exact joints, with their own half-step ceilings
$C crosscheck models/quadruped.wl --no-mjx $W --pipeline exact --out "$O/walk-exact" > "$O/walk-exact.log"
$C crosscheck models/quadruped.wl --no-mjx $R --pipeline exact --out "$O/s0-exact" > "$O/s0-exact.log"
for a in "3e5 300 1.25e-4" "3e6 1000 1.25e-4" "3e7 3000 3.125e-5" "3e8 10000 1e-5" "3e9 30000 3.125e-6"; do
  set -- $a
  $C crosscheck models/quadruped.wl --no-mjx --no-ceiling $W --dt "$3" --joint-spring "$1" "$2" --pipeline springs \
      --out "$O/walk-a$1" > "$O/walk-a$1.log"
  echo "walking set, alpha $1 at $3 s vs exact: $($P "$O/walk-exact/crosscheck.md" "$O/walk-a$1/crosscheck.md")"
  if [ "$1" != 3e9 ]; then
    $C crosscheck models/quadruped.wl --no-mjx --no-ceiling $R --dt "$3" --joint-spring "$1" "$2" --pipeline springs \
        --out "$O/s0-a$1" > "$O/s0-a$1.log"
    echo "random set, alpha $1 at $3 s vs exact: $($P "$O/s0-exact/crosscheck.md" "$O/s0-a$1/crosscheck.md")"
  fi
done
# is the stiffest step converged? alpha 3e8 at half its step
$C crosscheck models/quadruped.wl --no-mjx --no-ceiling $W --dt 5e-6 --joint-spring 3e8 10000 --pipeline springs \
    --out "$O/walk-a3e8-half" > "$O/walk-a3e8-half.log"
echo "walking set, alpha 3e8 against itself at half the step: $($P "$O/walk-a3e8/crosscheck.md" "$O/walk-a3e8-half/crosscheck.md")"
