# model: quadruped.wl, quadruped-stiff.wl
# pipeline: any
# controller: cpg
# picked: written by hand (no run)
# The hand-written trot of models/quadruped.wl (no evolution): one 0.5 Hz sinusoid per joint, the diagonal
# legs in phase (AR with PL, AL with PR) and the two pairs half a cycle apart; hips -0.2 +- 0.3 sin(pi t) rad,
# knees 0.4 + 0.4 sin(pi t + 2.07) rad, so that each foot swings forward while lifted.  Rows: HipAR, KneeAR,
# HipAL, KneeAL, HipPR, KneePR, HipPL, KneePL; columns c0, a1, b1, a2, b2 (docs/wl-format.md).
# What it does with today's code (tests/test_models.py replays each line and checks it):
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-trot.ctl  ->  walks +1.32 m in 10 s, stays up
#   cpgjax simulate models/quadruped.wl --ctl models/quadruped-trot.ctl --pipeline exact  ->  walks +1.44 m in 10 s, stays up
0.000000
-0.200000  0.300000  0.000000  0.000000  0.000000
0.400000  -0.191770  0.351033  0.000000  0.000000
-0.200000  -0.300000  0.000000  0.000000  0.000000
0.400000  0.191770  -0.351033  0.000000  0.000000
-0.200000  -0.300000  0.000000  0.000000  0.000000
0.400000  0.191770  -0.351033  0.000000  0.000000
-0.200000  0.300000  0.000000  0.000000  0.000000
0.400000  -0.191770  0.351033  0.000000  0.000000
