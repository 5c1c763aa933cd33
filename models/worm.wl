# A worm of five segments moved by one sinusoid per joint, each pi/2 behind the one before
# (thesis Appendix A, Fig. A.2).  Joints pitch about the transverse axis x: the wave
# travels along the body and the worm crawls.  Friction 2.5, 15 s, flat ground.
# Pair it with models/worm.ctl.

ColorDef      Green  .3 .7 .3

TimeMax       15.0
TextOnly
LogRate       20
Friction      2.5
Servo         8 0 0.1 3      # small motors
JointSpring   5e4 50         # light segments: a softer pivot spring keeps the default step stable
Terrain       flat
Track         Seg2

Object Seg0 {
    Type        Cube
    Color       Green
    Mass        0.2
    Dimensions  .06 .1 .04
    Position    0 0 .0205
}
Object Seg1 {
    Type        Cube
    Color       Green
    Mass        0.2
    Dimensions  .06 .1 .04
}
Object Seg2 {
    Type        Cube
    Color       Green
    Mass        0.2
    Dimensions  .06 .1 .04
}
Object Seg3 {
    Type        Cube
    Color       Green
    Mass        0.2
    Dimensions  .06 .1 .04
}
Object Seg4 {
    Type        Cube
    Color       Green
    Mass        0.2
    Dimensions  .06 .1 .04
}

Joint J0 {
    Seg0        0 -.055 0
    Seg1        0 .055 0
    Limits      -1.2 1.2
    ControlX
}
Joint J1 {
    Seg1        0 -.055 0
    Seg2        0 .055 0
    Limits      -1.2 1.2
    ControlX
}
Joint J2 {
    Seg2        0 -.055 0
    Seg3        0 .055 0
    Limits      -1.2 1.2
    ControlX
}
Joint J3 {
    Seg3        0 -.055 0
    Seg4        0 .055 0
    Limits      -1.2 1.2
    ControlX
}

Log Seg2 worm.log
