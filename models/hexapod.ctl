# model: hexapod.wl
# pipeline: any
# controller: cpg
# picked: written by hand after the thesis's Appendix A (no run)
# The tripod gait of models/hexapod.wl, written by hand after the thesis's Appendix A (no evolution): one
# 0.5 Hz sinusoid per joint, hip 0.4 rad and knee 0.3 rad in amplitude, each knee 3 pi / 4 after its hip (the
# thesis's pi/4 with this model's knee sign), the tripods AR-CL-PR and AL-CR-PL half a cycle apart.
# What it does with today's code (tests/test_models.py replays each line and checks it):
#   cpgjax simulate models/hexapod.wl --ctl models/hexapod.ctl --time 6  ->  walks +0.63 m in 6 s, stays up
#   cpgjax simulate models/hexapod.wl --ctl models/hexapod.ctl --pipeline exact  ->  walks +0.95 m in 10 s, stays up
0.000000
-0.250000  0.400000  0.000000  0.000000  0.000000
0.500000  -0.212132  0.212132  0.000000  0.000000
-0.250000  -0.400000  0.000000  0.000000  0.000000
0.500000  0.212132  -0.212132  0.000000  0.000000
-0.250000  0.400000  0.000000  0.000000  0.000000
0.500000  -0.212132  0.212132  0.000000  0.000000
-0.250000  -0.400000  0.000000  0.000000  0.000000
0.500000  0.212132  -0.212132  0.000000  0.000000
-0.250000  0.400000  0.000000  0.000000  0.000000
0.500000  -0.212132  0.212132  0.000000  0.000000
-0.250000  -0.400000  0.000000  0.000000  0.000000
0.500000  0.212132  -0.212132  0.000000  0.000000
