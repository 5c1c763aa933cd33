"""The static model: a `.wl` Description turned into fixed-size arrays (thesis Ch. 3.3-3.5).

A :class:`Model` is frozen: shapes, masses, inertias, contact vertices, pivot springs,
joints, servo gains and the terrain, shared by both physics pipelines, and the part of the pipeline
it runs on (:class:`~cpgjax.sim.springs.model.SpringsModel` or :class:`~cpgjax.sim.exact.tree.ExactModel`).
It is a plain Python object holding numpy arrays; jitted functions close over it, so its arrays become
compile-time constants.  :meth:`Model.replace` makes a new one.

A body is an Object or a Compound (objects welded together: masses and inertias combined
about the common centre of mass).  Body frames are the description frames (an object's
centre, a compound's Position); the state holds the centre of mass (CM) position and the
frame's orientation, and all local points are stored relative to the CM.

Every revolute joint has a pair of pivot points on each of its two bodies, ``+- width/2``
along the joint axis: the springs pipeline joins each pair with a pivot spring (eq. 3.6;
together they hold the pivot and the axis, and leave the rotation about the axis free); the
exact pipeline takes their middle as the joint's pivot.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass, field

import numpy as np

from cpgjax.sim.description import Description, DescriptionError, ObjectDef
from cpgjax.sim.exact.tree import ExactModel, build_exact
from cpgjax.sim.fingerprint import fingerprint
from cpgjax.sim.rotation import euler_to_mat, mat_to_quat, quat_to_mat_np
from cpgjax.sim.springs.model import SpringsModel, build_springs
from cpgjax.sim.terrain import Terrain, make_terrain, start_lift

# Defaults chosen by the time-step study (docs/simulator.md).
DEFAULT_DT = 5.0e-4
PIPELINES = ("springs", "exact")  # the thesis's pivot springs (eq. 3.6); exact joints (generalized coordinates)
DEFAULT_DT_EXACT = 2.0e-3  # the exact-joint pipeline's step (MuJoCo's default; docs/simulator.md)
DEFAULT_ALPHA = 3.0e5  # N/m   joint pivot spring (eq. 3.6)
DEFAULT_BETA = 300.0  # N s/m joint pivot damper (eq. 3.6)
# The friction bristle (sim.contact): soft, so that a walking robot's score is not chaotic; a stiffer one
# brings evolved gaits closer to MuJoCo's on average but makes the score chaotic again
# (docs/simulator.md, "The friction bristle: a trade-off").
DEFAULT_FRICTION_K = 1.0e3  # N/m
DEFAULT_FRICTION_B = 300.0  # N s/m
AXIS_WIDTH = 0.04  # m: distance between the two pivot springs of a revolute joint
LIMIT_STIFFNESS = 300.0  # N m / rad beyond a joint limit
LIMIT_DAMPING = 3.0  # N m s / rad beyond a joint limit
AXES = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}
REFS = {"X": np.array([0.0, 1.0, 0.0]), "Y": np.array([0.0, 0.0, 1.0]), "Z": np.array([1.0, 0.0, 0.0])}


@dataclass(frozen=True)
class EpisodeConfig:
    """What an episode of the model is, apart from its physics (the `.wl` file's ``TimeMax``, ``LogRate``,
    ``Harmonics`` and ``Frequency``): the default length [s] and log rate [1/s], and the CPG's number of harmonics
    K and base frequency f0 [Hz] (eq. 4.1)."""

    time_max: float
    log_rate: float
    harmonics: int
    frequency: float

    @staticmethod
    def of(desc: Description) -> EpisodeConfig:
        return EpisodeConfig(float(desc.time_max), float(desc.log_rate), int(desc.harmonics), float(desc.frequency))


@dataclass(frozen=True, eq=False)
class Model:
    """Frozen arrays of one robot and its world (hashed and compared by its structure, :attr:`fingerprint`): the
    shared part, and the part of its pipeline (``springs`` or ``exact``, the other None)."""

    # bodies [nb]
    body_names: tuple[str, ...]
    mass: np.ndarray  # [nb]
    inertia: np.ndarray  # [3, 3, nb] about the CM, body frame
    inv_inertia: np.ndarray  # [3, 3, nb]
    fixed: np.ndarray  # [nb] bool
    x0: np.ndarray  # [3, nb] initial CM positions
    q0: np.ndarray  # [4, nb] initial orientations (w, x, y, z)
    cm_local: np.ndarray  # [3, nb] CM in the body's description frame
    # points on bodies (pivot-spring ends and contact vertices) [npt]
    pt_body: np.ndarray  # [npt] int
    pt_local: np.ndarray  # [3, npt] relative to the CM, body frame
    pt_start: np.ndarray  # [nb + 1] the points of body b are pt_start[b]:pt_start[b+1] (sorted by body)
    # pivot springs [ns]: pairs of point indices
    sp_a: np.ndarray
    sp_b: np.ndarray
    # contacts [nc]: point indices
    ct_pt: np.ndarray
    # joints [nj]
    joint_names: tuple[str, ...]
    j_a: np.ndarray  # [nj] body index
    j_b: np.ndarray
    j_axis: np.ndarray  # [3, nj] local axis (same in both bodies' frames)
    j_ref: np.ndarray  # [3, nj] local reference vector, perpendicular to the axis
    j_lo: np.ndarray  # [nj] (-inf when no limit)
    j_hi: np.ndarray
    j_ctrl: np.ndarray  # [nj] index of the controlled DOF, -1 for passive joints
    j_kp: np.ndarray
    j_ki: np.ndarray
    j_kd: np.ndarray
    j_taumax: np.ndarray
    j_q0: np.ndarray  # [nj] initial joint angles
    ctrl_joint: np.ndarray  # [nctrl] joint index of each controlled DOF
    # world
    gravity: float
    ground_A: float
    ground_B: float
    mu_static: float
    mu_dynamic: float
    friction_k: float  # friction bristle spring [N/m] and damper [N s/m] (sim.contact)
    friction_b: float
    dt: float
    terrain: Terrain
    track: int  # body whose motion is scored and logged by default
    episode: EpisodeConfig  # the episode's length and log rate, the CPG's harmonics and frequency
    description: Description | None = field(default=None, repr=False)
    limit_k: float = LIMIT_STIFFNESS
    limit_c: float = LIMIT_DAMPING
    poly_atan2: bool = False  # a compiler trick, off (sim.tricks.poly_atan2; `cpgjax bench --tricks` measures it)
    pipeline: str = "springs"  # PIPELINES: which `step` runs it (`cpgjax.sim.pipeline.step` dispatches)
    springs: SpringsModel | None = field(default=None, repr=False)  # the springs pipeline's part
    exact: ExactModel | None = field(default=None, repr=False)  # the exact pipeline's part: its tree

    @property
    def nb(self) -> int:
        return len(self.body_names)

    @property
    def nj(self) -> int:
        return len(self.joint_names)

    @property
    def n_ctrl(self) -> int:
        return int(len(self.ctrl_joint))

    @property
    def n_coeff(self) -> int:
        return 2 * self.episode.harmonics + 1

    @property
    def n_genes(self) -> int:
        return self.n_ctrl * self.n_coeff

    @property
    def total_mass(self) -> float:
        return float(self.mass.sum())

    def body_index(self, name: str) -> int:
        return self.body_names.index(name)

    @functools.cached_property
    def fingerprint(self) -> str:
        """The structural hash of every field (:mod:`cpgjax.sim.fingerprint`): the model hashes and compares by it,
        so that compiled programs are cached by the model's structure, not by the object."""
        return fingerprint(self)

    def __hash__(self) -> int:
        return hash(self.fingerprint)

    def __eq__(self, other) -> bool:
        return self is other or (isinstance(other, Model) and self.fingerprint == other.fingerprint)

    @property
    def joint_spring(self) -> tuple[float, float]:
        """The springs pipeline's pivot springs (alpha [N/m], beta [N s/m]; eq. 3.6): its part's, else the
        description's ``JointSpring``, else the defaults."""
        if self.springs is not None:
            return self.springs.alpha, self.springs.beta
        js = self.description.joint_spring if self.description is not None else None
        return tuple(float(v) for v in js) if js else (DEFAULT_ALPHA, DEFAULT_BETA)

    def replace(self, *, joint_spring: tuple[float, float] | None = None, **changes) -> Model:
        """A new Model with some fields changed (e.g. ``dt``, ``gravity``, ``terrain``, ``pipeline``), its pipeline's
        part built again for them (``exact.materialize`` and the pivot springs carried over); ``joint_spring``:
        the springs pipeline's pivot springs (alpha, beta) instead."""
        new = dataclasses.replace(self, **changes)
        if "springs" in changes or "exact" in changes:
            return new
        return with_pipeline_part(new, materialize=self.exact.materialize if self.exact is not None else True,
                                  joint_spring=joint_spring or self.joint_spring)


def with_pipeline_part(model: Model, materialize: bool = True,
                       joint_spring: tuple[float, float] | None = None) -> Model:
    """``model`` with the part of its pipeline built (the other part None); ``joint_spring``: the springs
    pipeline's pivot springs (alpha, beta; None: :attr:`Model.joint_spring`)."""
    if model.pipeline == "exact":
        if model.description is None:
            raise ValueError("a Model needs its Description to run on exact joints")
        return dataclasses.replace(model, springs=None, exact=build_exact(model, model.description, materialize))
    return dataclasses.replace(model, springs=build_springs(model, *(joint_spring or model.joint_spring)), exact=None)


# ----------------------------------------------------------------------------- shapes

def object_inertia(obj: ObjectDef) -> np.ndarray:
    """Inertia tensor of a homogeneous Cube / Cylinder (axis x) / Sphere about its centre."""
    m, d = obj.mass, obj.dimensions
    t = obj.type.lower()
    if t == "cube":
        dx, dy, dz = d
        return m / 12.0 * np.diag([dy * dy + dz * dz, dx * dx + dz * dz, dx * dx + dy * dy])
    if t == "cylinder":
        r, length = d
        axial = 0.5 * m * r * r
        radial = m * (3 * r * r + length * length) / 12.0
        return np.diag([axial, radial, radial])
    if t == "sphere":
        r = d[0]
        return np.eye(3) * 0.4 * m * r * r
    raise DescriptionError("<model>", obj.line, f"unknown Type {obj.type!r}")


def object_contacts(obj: ObjectDef) -> np.ndarray:
    """Contact vertices of an object in its own frame [k, 3]."""
    if obj.contacts is not None:
        return np.asarray(obj.contacts, dtype=float).reshape(-1, 3)
    t = obj.type.lower()
    d = obj.dimensions
    if t == "cube":
        hx, hy, hz = (0.5 * v for v in d)
        return np.array([[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    if t == "cylinder":
        r, length = d
        n = obj.rim_points
        a = 2 * np.pi * np.arange(n) / n
        rims = [np.stack([np.full(n, s * length / 2), r * np.cos(a), r * np.sin(a)], 1) for s in (-1, 1)]
        return np.concatenate(rims)
    r = d[0]
    return np.concatenate([np.eye(3) * r, -np.eye(3) * r])


# ----------------------------------------------------------------------------- builder

def _check_body(path: str, desc: Description, kind: str, name: str, mass: float, inertia: np.ndarray,
                pts: list[np.ndarray]) -> None:
    """A body's mass and inertia must be finite and positive definite (the parser's ranges ensure it
    for a `.wl` file; this guards Descriptions made in code and combinations of extremes)."""
    what = f"{'Compound' if kind == 'compound' else 'Object'} '{name}'"
    line = desc.body_line(name)
    if not (np.isfinite(mass) and mass > 0 and np.all(np.isfinite(inertia))
            and all(np.all(np.isfinite(p)) for p in pts)):
        raise DescriptionError(path, line, f"{what}: its mass, inertia or contact vertices are not finite "
                                           f"(mass {mass:g} kg); check its Mass, Dimensions, Position and Contact")
    moments = np.linalg.eigvalsh(0.5 * (inertia + inertia.T))
    if not moments.min() > 1e-12 * moments.max() or not moments.min() > 0:
        raise DescriptionError(path, line, f"{what} has a degenerate inertia (principal moments "
                                           f"{', '.join(f'{v:.3g}' for v in moments)} kg m^2); check its Mass "
                                           "and Dimensions")


def file_dt(desc: Description, pipeline: str) -> float:
    """The step a model file asks for on ``pipeline``: on "exact" its ``ExactTimeStep``, else its
    ``TimeStep``, else :data:`DEFAULT_DT_EXACT`; on "springs" its ``TimeStep``, else :data:`DEFAULT_DT`."""
    if pipeline == "exact":
        return desc.exact_time_step or desc.time_step or DEFAULT_DT_EXACT
    return desc.time_step or DEFAULT_DT


def _contact_points(x0, q0, body, local) -> np.ndarray:
    """[3, n] world positions of contact vertices (bodies ``body``, offsets ``local`` from their CMs) in a pose."""
    R = quat_to_mat_np(q0[:, body])                                   # [3, 3, n]
    return x0[:, body] + np.einsum("ijn,jn->in", R, local)


def build_model(desc: Description, *, dt: float | None = None, terrain: str | None = None,
                pipeline: str | None = None) -> Model:
    """Turn a Description into a Model.  ``terrain`` (CLI syntax) overrides the file's; ``pipeline``
    ("springs" or "exact", see :data:`PIPELINES`) the file's ``Pipeline`` (default "springs")."""
    path = desc.path
    pipe = pipeline or desc.pipeline or "springs"
    if pipe not in PIPELINES:
        raise DescriptionError(path, desc.pipeline_line if pipeline is None else 0,
                               f"unknown pipeline {pipe!r}: choose one of {', '.join(PIPELINES)}")
    # -- bodies: root objects and compounds, in file order
    in_compound = {o for c in desc.compounds.values() for o in c.objects}
    entries = [(o.line, "object", o.name) for o in desc.objects.values() if o.name not in in_compound]
    entries += [(c.line, "compound", c.name) for c in desc.compounds.values()]
    entries.sort()
    names, masses, inertias, cms, fixed, contacts_local, frame_pose = [], [], [], [], [], [], {}
    for _, kind, name in entries:
        if kind == "object":
            o = desc.objects[name]
            members = [(o, np.zeros(3), np.eye(3))]
            pose = (np.asarray(o.position, float), euler_to_mat(*o.orientation))
            is_fixed = o.fixed
        else:
            c = desc.compounds[name]
            members = [
                (desc.objects[m], np.asarray(desc.objects[m].position, float),
                 euler_to_mat(*desc.objects[m].orientation))
                for m in c.objects
            ]
            pose = (np.asarray(c.position, float), euler_to_mat(*c.orientation))
            is_fixed = c.fixed
        m_tot = sum(o.mass for o, _, _ in members)
        cm = sum(o.mass * p for o, p, _ in members) / m_tot
        inertia = np.zeros((3, 3))
        pts = []
        for o, p, R in members:
            d = p - cm
            inertia += R @ object_inertia(o) @ R.T + o.mass * (d @ d * np.eye(3) - np.outer(d, d))
            pts.append(object_contacts(o) @ R.T + p)
        _check_body(path, desc, kind, name, m_tot, inertia, pts)
        names.append(name)
        masses.append(m_tot)
        inertias.append(inertia)
        cms.append(cm)
        fixed.append(is_fixed)
        contacts_local.append(np.concatenate(pts) - cm if pts else np.zeros((0, 3)))
        frame_pose[name] = pose
    nb = len(names)
    if nb == 0:
        raise DescriptionError(path, 1, "the description defines no Object, so there is nothing to simulate; "
                                        "add at least one Object block (docs/wl-format.md §4)")
    index = {n: i for i, n in enumerate(names)}

    # -- joints: place child bodies from their parents (a forest, checked by the parser)
    children = {j.body_b: j for j in desc.joints}
    placed: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    def place(name: str, depth: int = 0) -> tuple[np.ndarray, np.ndarray]:
        if name in placed:
            return placed[name]
        if depth > nb:
            raise DescriptionError(path, children[name].line, "joints form a cycle")
        if name not in children:
            placed[name] = frame_pose[name]
            return placed[name]
        j = children[name]
        pa, Ra = place(j.body_a, depth + 1)
        Rb = Ra @ euler_to_mat(*j.orientation)
        pivot_world = pa + Ra @ np.asarray(j.pivot_a, float)
        pb = pivot_world - Rb @ np.asarray(j.pivot_b, float)
        placed[name] = (pb, Rb)
        return placed[name]

    x0 = np.zeros((3, nb))
    q0 = np.zeros((4, nb))
    for i, n in enumerate(names):
        p, R = place(n)
        x0[:, i] = p + R @ cms[i]
        q0[:, i] = mat_to_quat(R)

    mass = np.asarray(masses)
    inertia = np.stack(inertias, -1)
    inv_inertia = np.stack([np.linalg.inv(I) for I in inertias], -1)

    # -- points: pivot-spring ends first, then contact vertices
    pt_body, pt_local = [], []
    sp_a, sp_b = [], []
    jd = desc.joints
    j_a, j_b, j_axis, j_ref, j_lo, j_hi, j_ctrl, j_q0 = [], [], [], [], [], [], [], []
    gains = []
    for j in jd:
        ia, ib = index[j.body_a], index[j.body_b]
        axis = AXES[j.axis.upper()]
        for s in (-0.5, 0.5):
            for bi, piv in ((ia, j.pivot_a), (ib, j.pivot_b)):
                pt_body.append(bi)
                pt_local.append(np.asarray(piv, float) + s * AXIS_WIDTH * axis - cms[bi])
            sp_a.append(len(pt_body) - 2)
            sp_b.append(len(pt_body) - 1)
        j_a.append(ia)
        j_b.append(ib)
        j_axis.append(axis)
        j_ref.append(REFS[j.axis.upper()])
        lo, hi = j.limits if j.limits is not None else (-np.inf, np.inf)
        j_lo.append(lo)
        j_hi.append(hi)
        j_ctrl.append(j.control_index if j.controlled else -1)
        j_q0.append(float(np.dot(np.asarray(j.orientation), axis)))
        sv = j.servo or desc.servo
        gains.append((sv.kp, sv.ki, sv.kd, sv.tau_max) if j.controlled else (0.0, 0.0, 0.0, 0.0))
    ct_pt = []
    for i in range(nb):
        for v in contacts_local[i]:
            ct_pt.append(len(pt_body))
            pt_body.append(i)
            pt_local.append(v)
    pt_body = np.asarray(pt_body, dtype=np.int32)
    pt_local = np.asarray(pt_local, float).reshape(-1, 3).T

    sp_a = np.asarray(sp_a, dtype=np.int32)
    sp_b = np.asarray(sp_b, dtype=np.int32)
    ct_pt = np.asarray(ct_pt, dtype=np.int32)
    # Sort points by body, so that summing point forces onto bodies is a sum over static
    # contiguous slices: bitwise the same for any batch size (a dot with an incidence matrix
    # is not: its summation order depends on the batch shape).
    perm = np.argsort(pt_body, kind="stable")
    new_of_old = np.empty_like(perm)
    new_of_old[perm] = np.arange(len(perm))
    pt_body, pt_local = pt_body[perm], pt_local[:, perm]
    sp_a, sp_b, ct_pt = new_of_old[sp_a], new_of_old[sp_b], new_of_old[ct_pt]
    pt_start = np.concatenate([[0], np.cumsum(np.bincount(pt_body, minlength=nb))]).astype(np.int32)

    nctrl = desc.n_controlled
    ctrl_joint = np.zeros(nctrl, dtype=np.int32)
    for k, c in enumerate(j_ctrl):
        if c >= 0:
            ctrl_joint[c] = k
    g = np.asarray(gains, float).reshape(-1, 4)

    track = index[desc.track] if desc.track else (
        next((i for i, n in enumerate(names) if n not in children), 0))
    A, B = desc.ground
    friction_k, friction_b = desc.friction_spring or (DEFAULT_FRICTION_K, DEFAULT_FRICTION_B)
    ground = make_terrain(terrain) if terrain else make_terrain(desc.terrain)
    if not any(fixed):      # the robot starts on its terrain, not in it (a robot with a fixed body stays put)
        lift = start_lift(ground, _contact_points(x0, q0, pt_body[ct_pt], pt_local[:, ct_pt]))
        if lift > 0.0:
            x0 = x0 + np.array([[0.0], [0.0], [lift]])
    model = Model(
        body_names=tuple(names), mass=mass, inertia=inertia, inv_inertia=inv_inertia,
        fixed=np.asarray(fixed, bool), x0=x0, q0=q0, cm_local=np.stack(cms, -1),
        pt_body=pt_body, pt_local=pt_local, pt_start=pt_start, sp_a=sp_a, sp_b=sp_b, ct_pt=ct_pt,
        joint_names=tuple(j.name for j in jd), j_a=np.asarray(j_a, np.int32), j_b=np.asarray(j_b, np.int32),
        j_axis=np.asarray(j_axis, float).reshape(-1, 3).T, j_ref=np.asarray(j_ref, float).reshape(-1, 3).T,
        j_lo=np.asarray(j_lo, float), j_hi=np.asarray(j_hi, float), j_ctrl=np.asarray(j_ctrl, np.int32),
        j_kp=g[:, 0], j_ki=g[:, 1], j_kd=g[:, 2], j_taumax=g[:, 3], j_q0=np.asarray(j_q0, float),
        ctrl_joint=ctrl_joint,
        gravity=float(desc.gravity), ground_A=float(A), ground_B=float(B),
        mu_static=float(desc.friction),
        mu_dynamic=float(desc.friction_dynamic if desc.friction_dynamic is not None else desc.friction),
        friction_k=float(friction_k), friction_b=float(friction_b),
        dt=float(dt or file_dt(desc, pipe)),
        terrain=ground,
        track=track, episode=EpisodeConfig.of(desc), description=desc, pipeline=pipe,
    )
    return with_pipeline_part(model)
