#!/bin/sh
# Steering without an oracle (docs/results/steering.md): a closed-loop gait
# evolved to follow a commanded turning rate, then each path walked by the gait alone, the command set every
# step from the robot's own pose.  Seeds 300, 301, 302 and the four paths were fixed before any was run.
# Each evolution: the hand-written trot as the start, exact joints, 4 episodes of 10 s per controller, each
# with a commanded rate U(-0.3, 0.3) rad/s per half, a fall forfeiting the episode, delta 1 (eq. 4.5: the score
# weighted by cos^2 of the body's tilt); population 40, 150 generations.  Then the run's best, and every path
# walked by every controller in one batch (cpgjax follow --ctl).  115-386 s of wall time per evolution on 2 shared
# cores (docs/results/steering.md).
#
#   sh benchmarks/steering.sh [OUT] [SEEDS]        # default runs/steering, "300 301 302"
#   REPLICAS=8 sh benchmarks/steering.sh runs/steering-r8 "303 304 305"   # 8 episodes per controller
#   COMMAND=0.5 sh benchmarks/steering.sh runs/steering-c05 "306 307 308"  # commands U(-0.5, 0.5) in evolution
#   SPEED=0.12 sh benchmarks/steering.sh runs/steering-v012 "312 313 314"  # speed credited up to 0.12 m/s
#   MIRROR=1 sh benchmarks/steering.sh runs/steering-mirror "315 316 317"  # a mirror-symmetric genome
#   MIRROR=1 SPEED=0.12 COMMAND=0.4 LIMIT=0.4 sh benchmarks/steering.sh runs/steering-c04-l04 "336 337 338"
#                                                   # the follower's limit (default 0.3) at the evolved command range
#   ... PERTURB=bristle=2,bristle_from=1 sh benchmarks/steering.sh ...   # more --perturb settings, appended
#   ... INPUTS=tilt+contact+command+steer+turn+bias ...   # what the policy reads (default without turn)
#
# A seed whose OUT/sS.ctl exists is not evolved again (the script resumes).  CPGJAX names the cpgjax executable
# (default .venv/bin/cpgjax); the wall and user time of each evolution is printed by /usr/bin/time.
set -e
case "${1:-}" in -h|--help) sed -n '2,/^set -e/{/^set -e/d;s/^# \{0,1\}//;p;}' "$0"; exit 0 ;; esac
OUT=${1:-runs/steering}
SEEDS=${2:-300 301 302}
CPGJAX=${CPGJAX:-.venv/bin/cpgjax}
mkdir -p "$OUT"
CTLS=""
for S in $SEEDS; do
    [ -f "$OUT/s$S.ctl" ] || {
        /usr/bin/time -f "s$S: %e s wall, %U s user" $CPGJAX evolve models/quadruped.wl \
            --start models/quadruped-trot.ctl --pipeline exact \
            --controller pmtg:${INPUTS:-tilt+contact+command+steer+bias}${MIRROR:+:mirror} --evaluation robust \
            --perturb command=${COMMAND:-0.3},fall_zero=on${REPLICAS:+,replicas=$REPLICAS}${SPEED:+,speed=$SPEED}${PERTURB:+,$PERTURB} --delta 1 --population 40 --generations 150 --time 10 \
            --pocket 4 --gamma 0.01 --chunk 10 --seed "$S" --out "$OUT/s$S.h5" --overwrite --quiet
        $CPGJAX best "$OUT/s$S.h5" --ctl "$OUT/s$S.ctl"
    }
    CTLS="$CTLS --ctl $OUT/s$S.ctl"
done
# shellcheck disable=SC2086
$CPGJAX follow models/quadruped.wl $CTLS --pipeline exact --limit ${LIMIT:-0.3} --time 120 \
    --path line:3 --path circle:0.5 --path square:1.0 --path figure8:0.5 --out "$OUT/walks.json"
