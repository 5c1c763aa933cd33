# model: quadruped.wl
# pipeline: exact
# controller: pmtg:tilt+contact+command+steer+bias:mirror
# time: 10
# terrain: flat
# command: 0.4
# run: runs/steer-b/s905.h5
# picked: best of generation 123 (robust score 0.1173, mean of 4 perturbed episodes)
# A closed-loop gait of models/quadruped.wl that turns when told to: its CPG modulated by a linear policy that reads
# the body's roll and pitch, the feet's contact, the commanded turning rate (alone and times the CPG's phase) and
# a bias, the same on both sides (docs/closed-loop.md, Steering).  Made by the steering recipe of
# docs/results/steering.md (seed 905; the run's best):
#   MIRROR=1 SPEED=0.12 COMMAND=0.4 LIMIT=0.4 sh benchmarks/steering.sh runs/steer-b "903 904 905"
#   cpgjax best runs/steer-b/s905.h5 --ctl models/quadruped-steer.ctl
# Chosen in our simulator alone (docs/results/steering.md, *The shipped steering gait*).  Not yet the walker of
# docs/results/walker.md: 0.23-0.25 m/s on 2 cm here, and in MuJoCo C it falls on the circle and the figure eight.
# What it does with today's code (tests/test_models.py replays each line and checks it).  Four lines state their own
# tolerance: the closed loop parts on the CPU and the vector unit there.  On an AMD EPYC: +2.30 m, 20.9 s, 31.9 s
# in MuJoCo C and 42.6 s with AVX-512 or AVX2, +2.50 m and 44.4 s with SSE4.2 only (XLA_FLAGS=--xla_cpu_max_isa=...);
# on an Intel Xeon: +2.15 m, 22.1 s and 33.4 s with AVX-512 or AVX2, +2.50 m and 21.1 s with SSE4.2.  The other
# lines were the same on all of them.
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-steer.ctl  ->  walks +2.87 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-steer.ctl --terrain rough:0.02:0.1:1  ->  walks +2.32 ±0.19 m in 10 s, stays up
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-steer.ctl --path line:3  ->  finished in 9.9 s, waypoints 1 of 1
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-steer.ctl --path line:3 --engine mujoco  ->  finished in 18.2 s, waypoints 1 of 1
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-steer.ctl --path circle:0.5  ->  finished in 21.5 ±0.7 s, waypoints 16 of 16
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-steer.ctl --path circle:0.5 --engine mujoco  ->  fell at 8.4 s, waypoints 5 of 16
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-steer.ctl --path square:1.0  ->  finished in 21.5 s, waypoints 4 of 4
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-steer.ctl --path square:1.0 --engine mujoco  ->  finished in 32.6 ±0.9 s, waypoints 4 of 4
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-steer.ctl --path figure8:0.5  ->  finished in 43.5 ±1.5 s, waypoints 32 of 32
#   cpgjax follow models/quadruped.wl --ctl models/quadruped-steer.ctl --path figure8:0.5 --engine mujoco  ->  fell at 8.4 s, waypoints 5 of 32
0.117254
-0.15788364  0.5292995  -0.040437516  0.10720277  -0.09803723
0.62891304  -0.058214977  0.623453  -0.05763332  -0.04157469
-0.15788364  -0.5292995  0.040437516  0.10720277  -0.09803723
0.62891304  0.058214977  -0.623453  -0.05763332  -0.04157469
-0.35378522  -0.075277515  -0.026741207  -0.14005373  0.01440747
0.44917867  0.1296019  -0.16799079  0.21445969  -0.2261302
-0.35378522  0.075277515  0.026741207  -0.14005373  0.01440747
0.44917867  -0.1296019  0.16799079  0.21445969  -0.2261302
Policy pmtg
Inputs tilt 2 contact 4 command 1 steer 2 bias 1
Outputs offsets 8 frequency 1 amplitude 1
# one line per output (offsets[8], frequency[1], amplitude[1]); columns: tilt[2] contact[4] command[1] steer[2] bias[1]
0.47802064  0.8  -0.16696535  -0.17209443  0.013603994  0.12842822  -0.096445575  0.08884509  -0.041119203  0.010885937
-0.042822566  -0.08564422  0.06747994  -0.26140618  -0.15925702  0.040161774  -0.1273263  0.1709513  -0.024576306  0.030346842
-0.47802064  0.8  -0.17209443  -0.16696535  0.12842822  0.013603994  0.096445575  0.08884509  -0.041119203  0.010885937
0.042822566  -0.08564422  -0.26140618  0.06747994  0.040161774  -0.15925702  0.1273263  0.1709513  -0.024576306  0.030346842
0.42378083  0.41310278  -0.06515828  0.01815102  0.01494012  -0.05302352  -0.1322414  -0.3623458  -0.4913978  -0.022721127
-0.8  -0.107997134  0.27261442  0.26853612  0.054366663  -0.1261397  -0.16846633  0.1290056  0.5320742  0.07306344
-0.42378083  0.41310278  0.01815102  -0.06515828  -0.05302352  0.01494012  0.1322414  -0.3623458  -0.4913978  -0.022721127
0.8  -0.107997134  0.26853612  0.27261442  -0.1261397  0.054366663  0.16846633  0.1290056  0.5320742  0.07306344
0.0  -0.34072036  0.8  0.8  0.131111  0.131111  0.0  2.3715427  0.16818921  0.7299812
0.0  -0.6980338  0.032505002  0.032505002  -0.24495997  -0.24495997  0.0  -0.69141954  1.2697777  0.06517845
