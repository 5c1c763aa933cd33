"""What a `.wl` description file says, as plain data (thesis Ch. 3.5.1).

The parser (`cpgjax.io.wl`) turns text into a :class:`Description`; the simulator's
model builder (`cpgjax.sim.model.build_model`) turns a Description into arrays.
Every record keeps the line it came from so that later checks can still report
``path:line: what is wrong``.

Conventions (documented in docs/wl-format.md):
- lengths in metres, masses in kg, angles in radians, time in seconds;
- world frame: x transverse (right), y forward, z up;
- an Object's frame is at its geometric centre with its axes along its Dimensions;
- a Compound's frame is its ``Position``; member Objects sit at their own
  ``Position``/``Orientation`` relative to it (default: at the compound origin);
- orientations are XYZ Euler angles (roll about x, then pitch about y, then yaw
  about z, applied in that order in the fixed frame: R = Rz @ Ry @ Rx);
- a Joint's two pivots are given in each body's own frame; the second body is
  placed from the first at start: pivots coincide and its orientation is the
  first's composed with the joint ``Orientation`` (the initial joint angle about
  the joint axis, for a revolute joint); joint angle 0 means the design pose.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from cpgjax.errors import DescriptionError  # noqa: F401  (re-exported: the description's error type)

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class ObjectDef:
    """``Object NAME { Type, Color, Mass, Dimensions, [Position], [Orientation], [Contact x y z]... }``.

    type: "Cube" (Dimensions dx dy dz, full edge lengths), "Cylinder" (Dimensions
    radius length; axis along the object's local x), "Sphere" (Dimensions radius).
    contacts: explicit contact vertices in the object's frame; ``None`` means the
    default set (Cube: its 8 corners; Cylinder: ``rim_points`` points on each rim;
    Sphere: 6 points at +-radius on each axis).  ``NoContact`` gives an empty tuple.
    """

    name: str
    type: str
    mass: float
    dimensions: tuple[float, ...]
    line: int
    color: str | None = None
    position: Vec3 = (0.0, 0.0, 0.0)
    orientation: Vec3 = (0.0, 0.0, 0.0)
    contacts: tuple[Vec3, ...] | None = None
    rim_points: int = 12
    fixed: bool = False  # welded to the world (a test rig)


@dataclass(frozen=True)
class CompoundDef:
    """``Compound NAME { OBJ ... Position x y z  Orientation rx ry rz [Fixed] }``: objects welded into one body."""

    name: str
    objects: tuple[str, ...]
    line: int
    position: Vec3 = (0.0, 0.0, 0.0)
    orientation: Vec3 = (0.0, 0.0, 0.0)
    fixed: bool = False


@dataclass(frozen=True)
class ServoDef:
    """PID position servo on a joint angle, with torque saturation (thesis Ch. 5: LM628 PID chips)."""

    kp: float = 60.0  # N m / rad
    ki: float = 0.0  # N m / (rad s)
    kd: float = 1.0  # N m s / rad
    tau_max: float = 17.5  # N m (0.35 N m motor x 50:1 gearbox)


@dataclass(frozen=True)
class JointDef:
    """``Joint NAME { BODY_A x y z  BODY_B x y z  Orientation a b c  Limits lo hi  ControlX|PassiveX ... }``.

    axis: "X", "Y" or "Z": the revolute axis, in the frame of body_a (and, at the
    design pose, of body_b). controlled: True for ``ControlX`` (driven by the CPG through
    the servo), False for ``PassiveX`` (free revolute, e.g. a wheel).
    control_index: order of controlled joints in the file (0, 1, ...), ``None`` if passive.
    orientation: the initial relative rotation of body_b (XYZ Euler, radians).
    servo: per-joint override of the file's ``Servo`` defaults (None: use them).
    """

    name: str
    body_a: str
    pivot_a: Vec3
    body_b: str
    pivot_b: Vec3
    line: int
    axis: str = "X"
    controlled: bool = True
    control_index: int | None = None
    orientation: Vec3 = (0.0, 0.0, 0.0)
    limits: tuple[float, float] | None = None
    servo: ServoDef | None = None


@dataclass(frozen=True)
class TerrainDef:
    """``Terrain flat`` | ``Terrain ramp SLOPE_RAD [X|Y]`` | ``Terrain bump HEIGHT Y [WIDTH]`` |
    ``Terrain rough RANGE [CELL [SEED]]`` | ``Terrain matrix NX NY X0 X1 Y0 Y1 { heights row by row }``.

    kind: "flat", "ramp", "bump", "rough" or "matrix"; params: the numbers after the kind;
    heights: for "matrix", NY rows of NX heights (row j is y index j).
    """

    kind: str = "flat"
    params: tuple[float, ...] = ()
    heights: tuple[tuple[float, ...], ...] | None = None
    axis: str = "Y"
    line: int = 0


@dataclass(frozen=True)
class LogDef:
    """``Log BODY FILE``: log a body's pose every 1/LogRate s (thesis Ch. 3.5.4)."""

    body: str
    file: str
    line: int


@dataclass
class Description:
    """Everything a `.wl` file says. Defaults are the thesis's settings where it gives them."""

    path: str = "<string>"
    text: str = ""
    colors: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    time_max: float = 8.0
    simulate: bool = False
    display: bool = True
    text_only: bool = False
    log_rate: float = 20.0
    friction: float = 1.0  # static friction coefficient
    friction_dynamic: float | None = None  # None: same as static
    gravity: float = 9.81
    time_step: float | None = None  # None: the simulator's default (from the stability study)
    # the exact pipeline's step (``ExactTimeStep``); None: ``time_step``, else DEFAULT_DT_EXACT
    exact_time_step: float | None = None
    ground: tuple[float, float] = (1.0e5, 1.0e3)  # A [kg/s^2], B [kg/s] (eq. 3.7)
    joint_spring: tuple[float, float] | None = None  # alpha [N/m], beta [N s/m] (eq. 3.6); None: default
    friction_spring: tuple[float, float] | None = None  # friction bristle k [N/m], b [N s/m]; None: default
    servo: ServoDef = field(default_factory=ServoDef)
    terrain: TerrainDef = field(default_factory=TerrainDef)
    track: str | None = None  # body whose motion is scored (default: first root body)
    objects: dict[str, ObjectDef] = field(default_factory=dict)  # in file order
    compounds: dict[str, CompoundDef] = field(default_factory=dict)  # in file order
    joints: list[JointDef] = field(default_factory=list)  # in file order
    logs: list[LogDef] = field(default_factory=list)
    harmonics: int = 2  # K of the CPG Fourier series
    frequency: float = 0.5  # f0 [Hz]
    # which physics pipeline runs the model (``Pipeline springs|exact``; None: the command's, else "springs"):
    # "springs" is the thesis's (every body free, joints as pivot springs, eq. 3.6, `sim.springs`);
    # "exact" is generalized coordinates (a floating base and one angle per revolute joint, `sim.exact`)
    pipeline: str | None = None
    pipeline_line: int = 0

    @property
    def n_controlled(self) -> int:
        return sum(1 for j in self.joints if j.controlled)

    def body_line(self, name: str) -> int:
        """The line of the Compound or Object that makes body ``name`` (1 if none)."""
        rec = self.compounds.get(name) or self.objects.get(name)
        return rec.line if rec is not None else 1
