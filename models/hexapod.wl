# A statically stable six-legged walker (thesis Appendix A, Fig. A.3): 12 DOFs, hip and
# knee of six legs about the transverse axis x.  One sinusoid per joint, upper and
# lower joint pi/4 apart (with our knee sign, positive = foot forward, that is a knee
# phase of 3pi/4 after the hip), so each foot goes round a closed path; the tripods
# AR-CL-PR and AL-CR-PL move in opposition of phase (models/hexapod.ctl).
# Friction 1.0, 10 s, flat ground.  Low and wide: it always has three feet down.

ColorDef      Brown  .7 .8 .5
ColorDef      Silver .7 .7 .8

TimeMax       10.0
TextOnly
LogRate       20
Friction      1.0
Servo         20 0 0.3 5
JointSpring   1e5 100        # light legs: a softer pivot spring
TimeStep      2.5e-4         # light legs on stiff ground: half the default step (study in docs/simulator.md)
# On exact joints the default 2 ms is converged: the tripod gait's 10 s distance (`cpgjax simulate
# models/hexapod.wl --ctl models/hexapod.ctl --pipeline exact --dt D`) is 0.9498, 0.9504, 0.9509, 0.9509,
# 0.9509 m at D = 2, 1, 0.5, 0.25, 0.125 ms (2 ms: -0.12 % of 0.125 ms), and 0 of 64 random controllers
# diverge at 2 ms (cpgjax study-dt --pipeline exact; docs/exact-joints.md).
ExactTimeStep 2e-3           # the exact pipeline's step (TimeStep above is the springs pipeline's)
Terrain       flat
Track         Body

Object Body {
    Type        Cube
    Color       Brown
    Mass        2.0
    Dimensions  .2 .45 .04
    Position    0 0 .2
}

Object UpAR {
    Type        Cube
    Color       Silver
    Mass        0.2
    Dimensions  .015 .025 .08
    Contact     0 0 -.04
}
Object LoAR {
    Type        Cube
    Color       Brown
    Mass        0.15
    Dimensions  .015 .025 .1
    Contact     0 0 -.055
}
Object UpCR {
    Type        Cube
    Color       Silver
    Mass        0.2
    Dimensions  .015 .025 .08
    Contact     0 0 -.04
}
Object LoCR {
    Type        Cube
    Color       Brown
    Mass        0.15
    Dimensions  .015 .025 .1
    Contact     0 0 -.055
}
Object UpPR {
    Type        Cube
    Color       Silver
    Mass        0.2
    Dimensions  .015 .025 .08
    Contact     0 0 -.04
}
Object LoPR {
    Type        Cube
    Color       Brown
    Mass        0.15
    Dimensions  .015 .025 .1
    Contact     0 0 -.055
}
Object UpAL {
    Type        Cube
    Color       Silver
    Mass        0.2
    Dimensions  .015 .025 .08
    Contact     0 0 -.04
}
Object LoAL {
    Type        Cube
    Color       Brown
    Mass        0.15
    Dimensions  .015 .025 .1
    Contact     0 0 -.055
}
Object UpCL {
    Type        Cube
    Color       Silver
    Mass        0.2
    Dimensions  .015 .025 .08
    Contact     0 0 -.04
}
Object LoCL {
    Type        Cube
    Color       Brown
    Mass        0.15
    Dimensions  .015 .025 .1
    Contact     0 0 -.055
}
Object UpPL {
    Type        Cube
    Color       Silver
    Mass        0.2
    Dimensions  .015 .025 .08
    Contact     0 0 -.04
}
Object LoPL {
    Type        Cube
    Color       Brown
    Mass        0.15
    Dimensions  .015 .025 .1
    Contact     0 0 -.055
}

Joint HipAR {
    Body        +0.12 +0.16 -.02
    UpAR        0 0 .035
    Limits      -1.5 1.5
    ControlX
}
Joint KneeAR {
    UpAR        0 0 -.035
    LoAR        0 0 .045
    Limits      -1.5 1.5
    ControlX
}
Joint HipCR {
    Body        +0.12 +0.00 -.02
    UpCR        0 0 .035
    Limits      -1.5 1.5
    ControlX
}
Joint KneeCR {
    UpCR        0 0 -.035
    LoCR        0 0 .045
    Limits      -1.5 1.5
    ControlX
}
Joint HipPR {
    Body        +0.12 -0.16 -.02
    UpPR        0 0 .035
    Limits      -1.5 1.5
    ControlX
}
Joint KneePR {
    UpPR        0 0 -.035
    LoPR        0 0 .045
    Limits      -1.5 1.5
    ControlX
}
Joint HipAL {
    Body        -0.12 +0.16 -.02
    UpAL        0 0 .035
    Limits      -1.5 1.5
    ControlX
}
Joint KneeAL {
    UpAL        0 0 -.035
    LoAL        0 0 .045
    Limits      -1.5 1.5
    ControlX
}
Joint HipCL {
    Body        -0.12 +0.00 -.02
    UpCL        0 0 .035
    Limits      -1.5 1.5
    ControlX
}
Joint KneeCL {
    UpCL        0 0 -.035
    LoCL        0 0 .045
    Limits      -1.5 1.5
    ControlX
}
Joint HipPL {
    Body        -0.12 -0.16 -.02
    UpPL        0 0 .035
    Limits      -1.5 1.5
    ControlX
}
Joint KneePL {
    UpPL        0 0 -.035
    LoPL        0 0 .045
    Limits      -1.5 1.5
    ControlX
}

Log Body hexapod.log
