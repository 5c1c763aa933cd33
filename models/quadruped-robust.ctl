# model: quadruped.wl
# pipeline: springs, exact
# controller: cpg
# time: 10
# terrain: flat
# run: runs/gif-sweep/ga_n20_mu0.2_g0.01_p4_xoff/s1.h5
# picked: best of the run (robust score 0.1417, mean of 4 perturbed episodes)
# An evolved gait of models/quadruped.wl that walks (the README's "evolved" GIF), made on the springs pipeline by
#   cpgjax sweep models/quadruped.wl --gamma 0.01 --pocket 4 --seeds 2 --generations 40 --evaluation robust --perturb fall_survival=on,bristle=3 --out runs/gif-sweep
#   cpgjax best runs/gif-sweep/ga_n20_mu0.2_g0.01_p4_xoff/s1.h5 --ctl models/quadruped-robust.ctl
# (seed 1's best; its first number below is the robust score the run recorded for it).  In MuJoCo C it scored
# 0.066 against 0.131 here, with no falls in 32 jittered replays in either engine (cpgjax transfer on its run).
# What it does with today's code (tests/test_models.py replays each line and checks it).  The first line states its
# own tolerance: the springs pipeline parts on the CPU there (+1.32 m on an AMD EPYC; on an Intel Xeon +1.40 m with
# AVX-512 or AVX2, +1.37 m with AVX, +1.28 m with SSE4.2 only: XLA_FLAGS=--xla_cpu_max_isa=...).
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-robust.ctl  ->  walks +1.32 ±0.09 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-robust.ctl --pipeline exact  ->  walks +0.51 m in 10 s, stays up
0.141703
0.13278216  0.2864794  0.14180012  0.035722304  -0.23589821
0.109958105  0.21796425  0.17252646  0.13770579  -0.1665127
0.2923415  0.25485843  0.06354816  -0.28275943  0.15358639
0.40307954  -0.052703954  -0.18554637  -0.18579355  -0.042521283
0.030409263  -0.010205726  -0.07769226  0.36300763  0.02864258
-0.2856396  0.18844235  -0.043011278  -0.1750227  -0.15594117
-0.16861024  0.25266656  0.04800183  -0.21239936  -0.13265681
0.01708689  0.18177675  0.11220449  0.2947472  0.12627554
