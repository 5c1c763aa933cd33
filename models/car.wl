# A small toy car going down a ramp with no control (thesis Appendix A, Fig. A.1):
# a chassis and four wheels on passive revolute joints.  Friction 1.0, 3.5 s.
# The ramp descends along +y with a slope of 0.2 rad, starting at y = 0.

ColorDef      Red    .8 .2 .2
ColorDef      Black  .1 .1 .1

TimeMax       3.5
TimeStep      1e-4             # light wheels: a smaller step than the default
TextOnly
LogRate       20
Friction      1.0
Terrain       ramp 0.2
Track         Chassis

Object Chassis {
    Type        Cube
    Color       Red
    Mass        0.5
    Dimensions  .1 .2 .03
    Position    0 .3 -.0185
    Orientation -.2 0 0
}
Object WheelFR {
    Type        Cylinder
    Color       Black
    Mass        0.05
    Dimensions  .03 .02
    RimPoints   16
}
Object WheelFL {
    Type        Cylinder
    Color       Black
    Mass        0.05
    Dimensions  .03 .02
    RimPoints   16
}
Object WheelRR {
    Type        Cylinder
    Color       Black
    Mass        0.05
    Dimensions  .03 .02
    RimPoints   16
}
Object WheelRL {
    Type        Cylinder
    Color       Black
    Mass        0.05
    Dimensions  .03 .02
    RimPoints   16
}
Joint AxleFR {
    Chassis     .065 .07 -.01
    WheelFR     0 0 0
    PassiveX
}
Joint AxleFL {
    Chassis     -.065 .07 -.01
    WheelFL     0 0 0
    PassiveX
}
Joint AxleRR {
    Chassis     .065 -.07 -.01
    WheelRR     0 0 0
    PassiveX
}
Joint AxleRL {
    Chassis     -.065 -.07 -.01
    WheelRL     0 0 0
    PassiveX
}

Log Chassis chassis.log
