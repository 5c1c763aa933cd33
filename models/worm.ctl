# model: worm.wl
# pipeline: any
# controller: cpg
# picked: written by hand after the thesis's Appendix A (no run)
# The worm's travelling wave, after the thesis's Appendix A (no evolution): one 0.5 Hz sinusoid of 0.5 rad
# per joint, each a quarter cycle from the one before (sin, cos, -sin, -cos).
# What it does with today's code (tests/test_models.py replays each line and checks it):
#   cpgjax simulate models/worm.wl --ctl models/worm.ctl --time 6  ->  crawls +0.14 m in 6 s, stays up
0.000000
0.000000  0.500000  0.000000  0.000000  0.000000
0.000000  0.000000  0.500000  0.000000  0.000000
0.000000  -0.500000  0.000000  0.000000  0.000000
0.000000  0.000000  -0.500000  0.000000  0.000000
