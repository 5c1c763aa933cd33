# The quadruped of models/quadruped.wl with feet that grip: a friction bristle 100 times stiffer and 10 times
# more damped (FrictionSpring 1e5 3000; the default 1e3 300 lets a touching foot slip about twice as fast as
# MuJoCo C's).  Gaits evolved on it fall here more often than on the default, and MuJoCo C still fails others
# that keep up here: the engines agree on no more fall verdicts (docs/results/walker-grip.md).  The score of one
# episode is chaotic on it (docs/results/engine-agreement-appendix.md): evolve on it with the robust evaluation.
# The walking robot of Grasso (2000), Ch. 5 and Appendix C.
# 13.8 kg in all, 8 DOFs (hip and knee of four identical legs, revolute about the
# body's transverse axis x).  Forward is +y, up is +z.  A = anterior, P = posterior,
# R = right (+x), L = left (-x).  With straight legs the feet just touch the ground
# at body height 0.322 m, as in the thesis's excerpt (Ch. 3.5.1).

ColorDef      Brown  .7 .8 .5
ColorDef      Blue   .4 .5 .7
ColorDef      Silver .7 .7 .8

TimeMax       10.0
Simulate      OFF
Display       ON
TextOnly
LogRate       20
Friction      2.5
FrictionSpring 1e5 3000     # bristle k [N/m], b [N s/m] (the default: 1e3 300)
Gravity       9.81
Ground        1e5 1e3          # A [kg/s^2], B [kg/s] (eq. 3.7)
Servo         60 0 1 17.5      # kp [Nm/rad] ki kd [Nms/rad] tau_max [Nm]
Terrain       flat
Track         Body

# ---------------------------------------------------------------- body: 10.6 kg
Object BodyBase {
    Type       Cube
    Color      Brown
    Mass       2.5
    Dimensions .25 .6 .02
}
Object Electronics {            # sensors, cabling and boards: the rest of the 13.8 kg
    Type       Cube
    Color      Silver
    Mass       0.5
    Dimensions .12 .2 .03
    Position   0 0 .025
    NoContact
}
Object GearBoxAR {
    Type       Cube
    Color      Blue
    Mass       1.9
    Dimensions .06 .12 .08
    Position   .09 .22 -.05
    NoContact
}
Object GearBoxAL {
    Type       Cube
    Color      Blue
    Mass       1.9
    Dimensions .06 .12 .08
    Position   -.09 .22 -.05
    NoContact
}
Object GearBoxPR {
    Type       Cube
    Color      Blue
    Mass       1.9
    Dimensions .06 .12 .08
    Position   .09 -.22 -.05
    NoContact
}
Object GearBoxPL {
    Type       Cube
    Color      Blue
    Mass       1.9
    Dimensions .06 .12 .08
    Position   -.09 -.22 -.05
    NoContact
}

Compound Body {
    BodyBase
    Electronics
    GearBoxAR
    GearBoxAL
    GearBoxPR
    GearBoxPL
    Position    0 0 .322
    Orientation 0 0 0
}

# ---------------------------------------------------------------- legs: upper 0.5 kg, lower 0.3 kg
Object LegUAR {
    Type       Cube
    Color      Silver
    Mass       0.5
    Dimensions .016 .035 .150
    Contact    0 0 -.075
}
Object LegUAL {
    Type       Cube
    Color      Silver
    Mass       0.5
    Dimensions .016 .035 .150
    Contact    0 0 -.075
}
Object LegUPR {
    Type       Cube
    Color      Silver
    Mass       0.5
    Dimensions .016 .035 .150
    Contact    0 0 -.075
}
Object LegUPL {
    Type       Cube
    Color      Silver
    Mass       0.5
    Dimensions .016 .035 .150
    Contact    0 0 -.075
}
# lower legs end in a rubber hemisphere: the foot tip is 1 cm below the segment
Object LegLAR {
    Type       Cube
    Color      Brown
    Mass       0.3
    Dimensions .021 .035 .162
    Contact    0 0 -.091
}
Object LegLAL {
    Type       Cube
    Color      Brown
    Mass       0.3
    Dimensions .021 .035 .162
    Contact    0 0 -.091
}
Object LegLPR {
    Type       Cube
    Color      Brown
    Mass       0.3
    Dimensions .021 .035 .162
    Contact    0 0 -.091
}
Object LegLPL {
    Type       Cube
    Color      Brown
    Mass       0.3
    Dimensions .021 .035 .162
    Contact    0 0 -.091
}

# ---------------------------------------------------------------- joints: 8 DOFs, +-1.5 rad
# hips at (+-0.14, +-0.22) under the plate, 1 cm below the top of each upper leg
Joint HipAR {
    Body        +0.14 +0.22 -.03
    LegUAR      0 0 .065
    Orientation 0 0 0
    Limits      -1.5 1.5
    ControlX
}
Joint KneeAR {
    LegUAR      0 0 -.065
    LegLAR      0 0 .071
    Orientation 0 0 0
    Limits      -1.5 1.5
    ControlX
}

Joint HipAL {
    Body        -0.14 +0.22 -.03
    LegUAL      0 0 .065
    Orientation 0 0 0
    Limits      -1.5 1.5
    ControlX
}
Joint KneeAL {
    LegUAL      0 0 -.065
    LegLAL      0 0 .071
    Orientation 0 0 0
    Limits      -1.5 1.5
    ControlX
}

Joint HipPR {
    Body        +0.14 -0.22 -.03
    LegUPR      0 0 .065
    Orientation 0 0 0
    Limits      -1.5 1.5
    ControlX
}
Joint KneePR {
    LegUPR      0 0 -.065
    LegLPR      0 0 .071
    Orientation 0 0 0
    Limits      -1.5 1.5
    ControlX
}

Joint HipPL {
    Body        -0.14 -0.22 -.03
    LegUPL      0 0 .065
    Orientation 0 0 0
    Limits      -1.5 1.5
    ControlX
}
Joint KneePL {
    LegUPL      0 0 -.065
    LegLPL      0 0 .071
    Orientation 0 0 0
    Limits      -1.5 1.5
    ControlX
}

Log Body body.log
