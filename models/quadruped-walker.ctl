# model: quadruped.wl
# pipeline: exact
# controller: pmtg:tilt+contact+command+steer+turn+bias:mirror
# time: 10
# terrain: flat
# command: 0.4
# run: runs/steer-es/tune/s1420.h5
# picked: champion of a validation: 0.1948 over 16 fresh perturbed episodes (seed 0), the highest of the run's 64 best; recorded 0.2256 at generation 111 (mean of 8 perturbed episodes)
# The steering walker: a closed-loop gait of models/quadruped.wl that walks the thesis's 0.42 m/s on 2 cm rough
# ground in both engines and turns when told to.  Its CPG is modulated by a linear policy that reads the body's roll
# and pitch, the feet's contact, the commanded turning rate (alone, times the CPG's phase, and its size) and a bias,
# the same on both sides (docs/closed-loop.md, Steering).  Its straight gait is models/quadruped-rough.ctl's, held:
# only the 22 weights that read the command were searched, by CMA-ES (docs/results/steering-walker.md; seed 1420,
# a tuning seed, on a CPU with AVX-512):
#   cpgjax search models/quadruped.wl --method cmaes --population 40 --samples 4800 --sigma 0.15 --pipeline exact \
#       --start models/quadruped-rough.ctl --controller pmtg:tilt+contact+command+steer+turn+bias:mirror \
#       --free command+steer+turn --evaluation robust \
#       --perturb preset=domain,latency=1,noise=0.02,bristle_from=1,touch=0.001,command=0.4,fall_survival=off,fall_zero=on,speed=0.5,turn_speed=0.15,overspeed=1,replicas=8,fall_tilt=40,stiffness=0.8,damping=0.8 \
#       --delta 1 --time 10 --seed 1420 --out runs/steer-es/tune/s1420.h5
#   cpgjax best runs/steer-es/tune/s1420.h5 --validate --ctl models/quadruped-walker.ctl
# Chosen in our simulator alone; MuJoCo C only judged it.
# What it does with today's code (tests/test_models.py replays each line and checks it).  Lines with a ± state their
# tolerance: the closed loop parts on the vector unit.  On an AMD EPYC, AVX-512 and AVX2 give the figures below
# (but the walks: circle 13.9 s, square 14.9 s, figure eight 27.4 s under AVX2); SSE4.2 alone +4.33, +4.48, +4.39,
# +4.15 and +4.34 m, and 7.1, 13.0, 14.7 and 29.2 s (XLA_FLAGS=--xla_cpu_max_isa=...).  MuJoCo C's lines move with
# numpy's vector unit, which the policy's arithmetic runs on there: without AVX-512 (NPY_DISABLE_CPU_FEATURES="X86_V4
# AVX512_ICL") +5.43, +5.94, +5.12, +5.70 and +6.18 m.  Its walks are at a 1 ms step, where both vector units finish
# each path in the same time; at 0.25 ms the figure eight finishes in 24.7 s with AVX-512 and falls at 14.8 s without
# (docs/results/steering-walker.md, The shipped walker).
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-walker.ctl  ->  walks +4.25 ±0.35 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-walker.ctl --terrain rough:0.02:0.1:1  ->  walks +4.21 ±0.35 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-walker.ctl --terrain rough:0.02:0.1:2  ->  walks +4.48 ±0.35 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-walker.ctl --terrain rough:0.02:0.1:3  ->  walks +4.45 ±0.35 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-walker.ctl --terrain rough:0.02:0.1:4  ->  walks +4.41 ±0.35 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-walker.ctl --engine mujoco --mujoco-dt 0.00025  ->  walks +5.43 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-walker.ctl --terrain rough:0.02:0.1:1 --engine mujoco --mujoco-dt 0.00025  ->  walks +5.87 ±0.5 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-walker.ctl --terrain rough:0.02:0.1:2 --engine mujoco --mujoco-dt 0.00025  ->  walks +5.56 ±0.5 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-walker.ctl --terrain rough:0.02:0.1:3 --engine mujoco --mujoco-dt 0.00025  ->  walks +5.58 ±0.5 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-walker.ctl --terrain rough:0.02:0.1:4 --engine mujoco --mujoco-dt 0.00025  ->  walks +6.26 ±0.5 m in 10 s, stays up
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-walker.ctl --path line:3  ->  finished in 7.1 s, waypoints 1 of 1
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-walker.ctl --path line:3 --engine mujoco --mujoco-dt 0.001  ->  finished in 5.5 s, waypoints 1 of 1
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-walker.ctl --path circle:0.5  ->  finished in 13.5 ±0.6 s, waypoints 16 of 16
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-walker.ctl --path circle:0.5 --engine mujoco --mujoco-dt 0.001  ->  finished in 12.1 s, waypoints 16 of 16
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-walker.ctl --path square:1.0  ->  finished in 15.5 ±1.0 s, waypoints 4 of 4
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-walker.ctl --path square:1.0 --engine mujoco --mujoco-dt 0.001  ->  finished in 13.0 s, waypoints 4 of 4
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-walker.ctl --path figure8:0.5  ->  finished in 26.9 ±2.5 s, waypoints 32 of 32
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-walker.ctl --path figure8:0.5 --engine mujoco --mujoco-dt 0.001  ->  finished in 24.4 ±0.3 s, waypoints 32 of 32
# one line per output (offsets[8], frequency[1], amplitude[1]); columns: tilt[2] contact[4] command[1] steer[2] turn[1] bias[1]
0.225566
-0.119351394  0.36081466  0.05291976  0.40399182  -0.030579891
0.46766394  -0.38623127  0.34877357  -0.583571  -0.19563366
-0.119351394  -0.36081466  -0.05291976  0.40399182  -0.030579891
0.46766394  0.38623127  -0.34877357  -0.583571  -0.19563366
-0.23371822  -0.1571539  0.36658382  0.110018976  -0.37061134
-0.21196386  -0.07848801  -0.6230112  -0.06834141  0.5565348
-0.23371822  0.1571539  -0.36658382  0.110018976  -0.37061134
-0.21196386  0.07848801  0.6230112  -0.06834141  0.5565348
Policy pmtg
Inputs tilt 2 contact 4 command 1 steer 2 turn 1 bias 1
Outputs offsets 8 frequency 1 amplitude 1
-0.08347462  -0.17831795  -0.21091887  -0.0017346217  0.047510587  0.004016538  -0.012766659  -1.4066828  -1.4301819  -0.37118232  0.13708155
0.27408847  0.61179036  -0.14136922  -0.041405614  -0.054097496  -0.005261984  -0.111724645  1.4896721  1.3534192  1.5920264  -0.11797948
0.08347462  -0.17831795  -0.0017346217  -0.21091887  0.004016538  0.047510587  0.012766659  -1.4066828  -1.4301819  -0.37118232  0.13708155
-0.27408847  0.61179036  -0.041405614  -0.14136922  -0.005261984  -0.054097496  0.111724645  1.4896721  1.3534192  1.5920264  -0.11797948
0.11075245  0.21434379  -0.092084534  0.024282213  -0.0745712  0.1042378  0.39961085  -1.4831439  0.9587747  1.242647  0.1691557
-0.31408992  0.15880314  -0.023796232  -0.26345822  -0.13836516  0.010310295  -0.38238534  1.2324408  -1.4408344  -1.2184075  -0.079689465
-0.11075245  0.21434379  0.024282213  -0.092084534  0.1042378  -0.0745712  -0.39961085  -1.4831439  0.9587747  1.242647  0.1691557
0.31408992  0.15880314  -0.26345822  -0.023796232  0.010310295  -0.13836516  0.38238534  1.2324408  -1.4408344  -1.2184075  -0.079689465
0.0  -0.41585633  0.3190149  0.3190149  0.4447228  0.4447228  0.0  1.5174482  1.091121  -0.55393887  0.71701825
0.0  0.22967412  -0.11314694  -0.11314694  -0.08732352  -0.08732352  0.0  0.69844997  1.3714975  -1.5826093  0.00254073
